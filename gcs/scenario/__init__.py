"""The scenario format: TOML files read into frozen dataclasses (`reader`), field by field (`fields`), what a
scenario means to the models (`model_params`), its JSON Schema (`schema`), its `[acoustic]` table and TDMA frame."""
