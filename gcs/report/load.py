"""Which way a report reads a run: its traces.npz where the run wrote one with what a report draws
(`gcs.report.traces`: a cost that does not grow with the mission), else its GCS log
replayed (`gcs.report.run_data.load_replayed_run`: older run folders, restored consoles)."""

from __future__ import annotations

from pathlib import Path

from gcs.records.playback import find_scenario, run_files
from gcs.report.run_data import RunData, check_result, load_replayed_run
from gcs.report.traces import read_traces, traced_run


def load_run(run: str | Path, scenario: str | Path | None = None) -> RunData:
    """Everything a report shows of one run; `ReplayError` / `ScenarioError` on bad input."""
    files = run_files(run)
    traces = read_traces(files.run.traces)
    if traces is None:
        return load_replayed_run(run, scenario)
    check_result(files.result, files.run.result)
    return traced_run(files, find_scenario(files, scenario), traces)
