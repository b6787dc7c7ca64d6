"""The same sweep on a local cluster and on a separately started `dask scheduler` with two `dask
worker` processes gives the same rows (but the wall times)."""

from __future__ import annotations

import io
from collections.abc import Iterator
from pathlib import Path

import pandas as pd
import pytest
from rich.console import Console
from testkit import dask_processes

from gcs.sweep.cells import make_cells
from gcs.sweep.runner import sweep
from gcs.sweep.spec import load_spec

SPEC = """
[sweep]
scenarios = ["pool12"]
strategies = {strategies}
seeds = "{seeds}"
[set]
mission.duration = "{duration}"
mission.theta = 60
"""


@pytest.fixture(scope="module")
def scheduler(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """One `dask scheduler` with its two `dask worker` processes for the file's sweeps: starting them is
    seconds of imports, and a worker keeps nothing of one sweep's missions for the next."""
    with dask_processes(tmp_path_factory.mktemp("dask")) as address:
        yield address


def figures(out: Path) -> pd.DataFrame:
    rows = pd.read_parquet(out / "results.parquet")
    return rows.drop(columns=[c for c in rows.columns if c.endswith("wall_s")])


def same_rows_on_both(tmp_path: Path, text: str, local_processes: bool, address: str) -> pd.DataFrame:
    (tmp_path / "spec.toml").write_text(text)
    spec = load_spec(tmp_path / "spec.toml")
    cells = make_cells(spec)
    console = Console(file=io.StringIO())
    local = sweep(spec, cells, tmp_path / "local", console, workers=2 if local_processes else 1,
                  processes=local_processes)
    remote = sweep(spec, cells, tmp_path / "remote", console, scheduler=address)
    assert local.ran == remote.ran == len(cells) and not local.failed and not remote.failed
    rows = figures(tmp_path / "local")
    pd.testing.assert_frame_equal(rows, figures(tmp_path / "remote"))
    assert list(rows["cell"]) == [c.key for c in cells]
    return rows


def test_a_separate_scheduler_and_two_workers_give_the_local_rows(tmp_path: Path, scheduler: str) -> None:
    """CI variant: two missions long enough to collect, the local cluster in this process (the local
    cluster's worker processes, as `vil sweep` starts them, are tests/plugins' and test_sweep_interrupt's)."""
    rows = same_rows_on_both(tmp_path, SPEC.format(strategies='["cautious", "greedy"]', seeds="1-1", duration="6m"),
                             local_processes=False, address=scheduler)
    assert len(rows) == 2 and (rows["cost_m"] > 0).any()


@pytest.mark.slow
@pytest.mark.long
def test_a_separate_scheduler_and_two_workers_give_the_local_rows_of_real_missions(tmp_path: Path,
                                                                                  scheduler: str) -> None:
    """Six missions long enough to collect, the local cluster as `vil sweep` starts it (processes);
    make test runs the CI variant above (a second cluster start and six missions: the suite's time)."""
    rows = same_rows_on_both(tmp_path, SPEC.format(strategies='["cautious", "greedy"]', seeds="1-3", duration="6m"),
                             local_processes=True, address=scheduler)
    assert len(rows) == 6 and (rows["cost_m"] > 0).any()


def test_an_event_platform_sweep_gives_the_local_rows_on_a_separate_scheduler(tmp_path: Path,
                                                                             scheduler: str) -> None:
    """`platform = "event"` in a spec (issue 37): every cell runs on the event platform, on a local cluster and
    on a separately started scheduler with workers alike, and its rows say so. Missions of 6 minutes, as above:
    every cell collects (cost > 0) in them, and 40 took 8 s of the suite's time for nothing more checked."""
    text = SPEC.format(strategies='["cautious", "greedy"]', seeds="1-2", duration="6m") + '\n'
    text = text.replace('seeds = "1-2"', 'seeds = "1-2"\nplatform = "event"')
    rows = same_rows_on_both(tmp_path, text, local_processes=False, address=scheduler)
    assert len(rows) == 4 and (rows["cost_m"] > 0).all()
    platform = [c for c in rows.columns if c.endswith("platform")]
    assert platform and set(rows[platform[0]]) == {"event"}, list(rows.columns)


def test_the_sensitivity_and_tuning_studies_run_unchanged_on_a_separate_scheduler(
    tmp_path: Path, scheduler: str, capsys: pytest.CaptureFixture[str],
) -> None:
    """Issue 38: the shipped sensitivity study (n = 2, 3-minute missions) and the tuning example (2 trials of one
    10-minute mission, 1 held-out seed) on a separately started scheduler and workers, as on a local cluster."""
    from testkit import MISSIONS

    from gcs.cli.main import main

    bay = '"' + str(MISSIONS / "bay-capacity.toml") + '"'
    text = (MISSIONS / "sweeps/sensitivity.toml").read_text().replace('"6h"', '"3m"').replace('"bay-capacity"', bay)
    (tmp_path / "s.toml").write_text(text)
    assert main(["sweep", str(tmp_path / "s.toml"), "--out", str(tmp_path / "s"), "--scheduler", scheduler,
                 "--base-samples", "2"]) == 0
    assert "sobol indices over 8 fields, 36 points (n = 2)" in capsys.readouterr().out
    text = (MISSIONS / "tune/cautious-40.toml").read_text()
    text = (text.replace("trials = 40", "trials = 2").replace('seeds = "1-3"', "seeds = [1]")
            .replace('held_out = "101-120"', "held_out = [101]").replace('"24h"', '"10m"')
            .replace('"bay-capacity"', bay))
    (tmp_path / "t.toml").write_text(text)
    assert main(["tune", str(tmp_path / "t.toml"), "--out", str(tmp_path / "t"), "--scheduler", scheduler]) == 0
    printed = capsys.readouterr().out
    assert "2 trials: best uptime_min" in printed and "1 held-out seeds (101-101)" in printed
    assert (tmp_path / "t" / "best.toml").is_file()
