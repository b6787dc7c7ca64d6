"""A mission run: its world built (`world`), its lifecycle for every front end (`session`), headless in
lockstep (`headless`), and what it leaves (`outcome`, `apad_record`, `time_accounting`)."""
