"""`vil sweep`: many headless missions over a grid or a sample of scenario fields, on Dask.

spec (the TOML spec, validated whole before anything runs) -> cells (one mission each, run on a
worker) -> store (a file per finished cell, then results.parquet / results.csv) -> report.
"""
