"""The acoustic sweep's table from real cells: the shipped spec's grid (acoustic.enabled false and true)
on pool12, one strategy and seed, 5-minute missions, each cell run in lockstep and stored as `vil sweep`
stores it (no Dask here: the sweep runner's own path is tests/sweep/test_sweep_run.py's)."""

from __future__ import annotations

from pathlib import Path

import pytest

from gcs.sweep.acoustic_compare import compare_table, main, read_missions, verdicts
from gcs.sweep.cells import make_cells, run_cell
from gcs.sweep.spec import load_spec
from gcs.sweep.store import write_cell

MISSIONS = Path(__file__).resolve().parents[2] / "missions"


@pytest.fixture(scope="module")
def swept(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("acoustic")
    text = (MISSIONS / "sweeps/acoustic.toml").read_text()
    text = text.replace('scenarios = ["pool12", "bay24"]', f'scenarios = ["{MISSIONS}/pool12.toml"]')
    text = text.replace('strategies = "all"', 'strategies = ["cautious"]').replace('seeds = "1-20"', "seeds = [1]")
    spec_path = folder / "tiny.toml"
    spec_path.write_text(text + '\n[set]\nmission.duration = "5m"\n')
    for cell in make_cells(load_spec(spec_path)):
        write_cell(folder / "out", cell, run_cell(cell))
    return folder / "out"


def test_the_table_sets_the_channel_off_against_on_for_the_same_seeds(swept: Path) -> None:
    rows = read_missions(swept)
    assert sorted(rows["acoustic"].tolist()) == [False, True]
    off, on = rows[~rows["acoustic"]].iloc[0], rows[rows["acoustic"]].iloc[0]
    assert off["error_pct"] is None or off["error_pct"] != off["error_pct"]  # no channel, no estimate error
    assert 0.0 < on["heard_pct"] <= 100.0 and on["age_median_s"] > 0.0 and on["error_pct"] >= 0.0
    table = compare_table(rows)
    assert len(table) == 1
    r = table.iloc[0]
    assert (r["scenario"], r["strategy"], r["seeds"]) == ("pool12", "cautious", 1)
    assert r["uptime off %"] == round(off["uptime_avg"], 2) and r["uptime on %"] == round(on["uptime_avg"], 2)
    assert r["change"] == round(on["uptime_avg"] - off["uptime_avg"], 2)
    assert verdicts(table) == [f"pool12: best with the channel on: cautious ({r['uptime on %']:.2f} % mean uptime, "
                               f"{r['change']:+.2f} against off); best change against off: cautious "
                               f"({r['change']:+.2f})"]


def test_the_command_prints_the_table_and_refuses_an_empty_folder(swept: Path, tmp_path: Path,
                                                                  capsys: pytest.CaptureFixture[str]) -> None:
    assert main([str(swept)]) == 0
    out = capsys.readouterr().out
    assert "| uptime off % | uptime on % |" in out and "pool12: best with the channel on: cautious" in out
    assert main([str(tmp_path)]) == 2
    assert capsys.readouterr().err.startswith(f"acoustic_compare: {tmp_path}: no finished missions")
