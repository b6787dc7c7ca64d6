"""Real sweeps on a real Dask cluster: rows, resume, the command line and the report."""

from __future__ import annotations

import io
from pathlib import Path

import pandas as pd
import pytest
from distributed import LocalCluster
from rich.console import Console

from gcs.cli.main import main
from gcs.mission.headless import run_mission
from gcs.sweep.cells import make_cells
from gcs.sweep.runner import sweep
from gcs.sweep.spec import load_spec

# Two short missions that differ by a swept field; fast aMussels (theta 60) make the aPad collect in 6 min.
TINY = """
[sweep]
scenarios = ["pool12"]
strategies = ["cautious"]
seeds = [2]
[set]
mission.duration = "6m"
mission.theta = 60
[grid]
mission.pool_threshold = [0.8, 0.9]
"""
FIGURES = ["uptime.avg", "uptime.min", "uptime.max", "cost_m", "active_avg", "wall_s", "cycles", "end_reason",
           "mussels.n", "mussels.uptime_pct.min", "mussels.dockings.max", "messages.gcs_sent", "apads.cost_m.mean",
           "whereabouts.n"]


def quiet() -> Console:
    return Console(file=io.StringIO(), width=200)


def test_a_sweep_writes_one_row_per_mission_and_resumes(tmp_path: Path) -> None:
    (tmp_path / "tiny.toml").write_text(TINY)
    spec = load_spec(tmp_path / "tiny.toml")
    cells = make_cells(spec)
    out = tmp_path / "out"
    first = sweep(spec, cells, out, quiet(), workers=1, processes=False)
    assert (first.cells, first.skipped, first.ran, first.failed, first.rows) == (2, 0, 2, [], 2)
    assert sorted(p.stem for p in (out / "cells").glob("*.json")) == sorted(c.key for c in cells)

    rows = pd.read_parquet(out / "results.parquet")
    assert list(rows["cell"]) == [c.key for c in cells]
    assert list(rows.columns[:5]) == ["cell", "scenario", "strategy", "seed", "mission.pool_threshold"]
    assert set(FIGURES) <= set(rows.columns)
    assert list(rows["mission.pool_threshold"]) == [0.8, 0.9]
    assert (rows["duration_s"] == 360).all() and (rows["mussels.n"] == 12).all()
    assert rows["cost_m"].iloc[1] > 0  # the higher threshold sends the aPad out
    csv = pd.read_csv(out / "results.csv")
    assert list(csv.columns) == list(rows.columns) and len(csv) == 2

    # A row holds what `vil run` gives for the same mission.
    alone = run_mission(cells[1].scenario)
    assert rows["uptime.avg"].iloc[1] == alone.uptime["avg"] and rows["cost_m"].iloc[1] == alone.cost_m

    active = pd.read_parquet(out / "active.parquet")
    for key in rows["cell"]:
        series = active[active["cell"] == key]
        assert list(series["t_s"]) == [10.0 * k for k in range(1, 37)]
        assert series["active"].between(0, 12).all()
    run = rows.iloc[1]
    assert active[active["cell"] == run["cell"]]["active"].mean() == pytest.approx(run["active_avg"], abs=0.05)

    again = sweep(spec, cells, out, quiet(), workers=1, processes=False)
    assert (again.skipped, again.ran, again.rows) == (2, 0, 2)
    pd.testing.assert_frame_equal(pd.read_parquet(out / "results.parquet"), rows)


def test_the_command_on_an_existing_scheduler_and_its_report(
    tmp_path: Path, capsys: pytest.CaptureFixture[str],
) -> None:
    spec = tmp_path / "tiny.toml"
    spec.write_text(TINY.replace("seeds = [2]", "seeds = [3]").replace("[0.8, 0.9]", "[0.9]").replace("6m", "3m")
                    .replace('strategies = ["cautious"]', 'strategies = ["cautious", "none"]'))
    out = tmp_path / "out"
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=":0") as cluster:
        assert main(["sweep", str(spec), "--out", str(out), "--scheduler", cluster.scheduler_address]) == 0
    printed = capsys.readouterr().out
    assert "2 missions, 0 already" in printed and "ran 2 missions" in printed
    rows = pd.read_parquet(out / "results.parquet")
    assert list(rows["strategy"]) == ["cautious", "none"] and (rows["cost_m"].iloc[1] == 0)
    report = out / "report"
    for name in ("summary.csv", "summary.md", "pareto.png", "uptime.png", "active.png"):
        assert (report / name).stat().st_size > 0
    summary = pd.read_csv(report / "summary.csv")
    assert list(summary["config"]) == ["cautious pool_threshold=0.9", "none pool_threshold=0.9"]
    assert list(summary["n"]) == [1, 1]

    # Resumed: nothing runs, so no cluster is needed; the report is written again on its own.
    assert main(["sweep", str(spec), "--out", str(out), "--scheduler", "tcp://127.0.0.1:9", "--no-report"]) == 0
    assert "2 already in" in capsys.readouterr().out
    (report / "summary.md").unlink()
    assert main(["sweep", "report", str(out)]) == 0
    assert "Pareto" in capsys.readouterr().out and (report / "summary.md").exists()


def test_bad_input_is_one_line_and_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    spec = tmp_path / "bad.toml"
    spec.write_text('[sweep]\nscenarios = ["pool12"]\n[grid]\nmission.theta = [-1]\n')
    assert main(["sweep", str(spec), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "mission.theta: -1 is outside" in err
    assert not (tmp_path / "out").exists()  # nothing written for a spec that does not hold
    assert main(["sweep", "report", str(tmp_path)]) == 2
    assert "not a sweep folder" in capsys.readouterr().err
    assert main(["sweep", str(spec)]) == 2
    assert "--out DIR is required" in capsys.readouterr().err
    with pytest.raises(SystemExit) as refused:
        main(["sweep", str(spec), "--out", str(tmp_path / "out"), "--seeds", "0"])
    assert refused.value.code == 2 and "argument --seeds: 0 is outside" in capsys.readouterr().err


def test_the_usage_shows_out_as_required(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["sweep", "--help"])
    usage = capsys.readouterr().out.split("\n\n")[0]
    assert usage.splitlines() == ["usage: vil sweep SPEC.toml --out DIR [--seeds N] [options]",
                                  "       vil sweep report DIR"]


def test_seeds_n_runs_the_specs_first_n_seeds_and_the_whole_spec_keeps_them(
    tmp_path: Path, capsys: pytest.CaptureFixture[str],
) -> None:
    spec = tmp_path / "three.toml"
    spec.write_text('[sweep]\nscenarios = ["pool12"]\nstrategies = ["none"]\nseeds = "4-6"\n'
                    '[set]\nmission.duration = "1m"\n')
    out = tmp_path / "out"
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=":0") as cluster:
        args = ["sweep", str(spec), "--out", str(out), "--scheduler", cluster.scheduler_address, "--no-report"]
        assert main([*args, "--seeds", "2"]) == 0
        assert "2 missions, 0 already" in capsys.readouterr().out
        assert list(pd.read_parquet(out / "results.parquet")["seed"]) == [4, 5]
        assert main(args) == 0
        assert "3 missions, 2 already" in capsys.readouterr().out
    assert list(pd.read_parquet(out / "results.parquet")["seed"]) == [4, 5, 6]


def test_a_failed_mission_is_listed_not_written_and_tried_again(tmp_path: Path) -> None:
    (tmp_path / "one.toml").write_text(TINY.replace("[0.8, 0.9]", "[0.8]").replace("6m", "1m"))
    spec = load_spec(tmp_path / "one.toml")
    cells = make_cells(spec)
    out = tmp_path / "out"
    out.mkdir()
    (out / "runs").write_text("a file where --keep-runs puts the missions' folders")
    failed = sweep(spec, cells, out, quiet(), workers=1, processes=False, keep_runs=True)
    assert (failed.ran, failed.rows, [f.cell.key for f in failed.failed]) == (0, 0, [cells[0].key])
    assert "Error" in failed.failed[0].why and "\n" not in failed.failed[0].why
    assert not (out / "cells").exists() and not (out / "results.parquet").exists()
    assert "Traceback" in (out / "failed.txt").read_text()

    (out / "runs").unlink()
    again = sweep(spec, cells, out, quiet(), workers=1, processes=False, keep_runs=True)
    assert (again.skipped, again.ran, again.failed, again.rows) == (0, 1, [], 1)
    assert not (out / "failed.txt").exists()
    assert pd.read_parquet(out / "results.parquet")["run_dir"].iloc[0].startswith(str(out / "runs"))
