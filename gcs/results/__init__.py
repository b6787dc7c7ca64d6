"""A run's results as data: result.json's types (`run_result`), the per-day figures (`days`) and where every
aMussel ended (`accounting`). Nothing here draws or prints: the tables are the front ends' (`gcs.cli.tables`)."""
