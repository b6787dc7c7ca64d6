"""The capacity study's path on a real Dask cluster: a tiny sweep of the fleet's size per behaviour profile
([[grid]] blocks) and strategy, then its table and figure (`gcs.sweep.capacity`, docs/capacity.md)."""

from __future__ import annotations

import io
import re
from pathlib import Path

import pandas as pd
from rich.console import Console

from gcs.sweep.capacity import agreement, capacity_table, main, read_missions
from gcs.sweep.cells import make_cells
from gcs.sweep.runner import sweep
from gcs.sweep.spec import load_spec

MISSIONS = Path(__file__).resolve().parents[2] / "missions"


def tiny_of_shipped() -> str:
    """missions/sweeps/capacity.toml in short form: its strategies, profiles and platform, the smallest size of
    each profile, one seed, 3-minute missions (docs/capacity.md's study, as the suite runs it)."""
    spec = (MISSIONS / "sweeps/capacity.toml").read_text()
    spec = spec.replace('mission.duration = "24h"', 'mission.duration = "3m"').replace('seeds = "1-10"', "seeds = [1]")
    spec = re.sub(r"fleet\.count = \[(\d+), [^]]*\]", r"fleet.count = [\1]", spec)
    return spec.replace('"bay-capacity"', '"' + str(MISSIONS / "bay-capacity.toml") + '"')


def test_a_tiny_capacity_sweep_gives_its_table_and_figure(tmp_path: Path) -> None:
    (tmp_path / "tiny.toml").write_text(tiny_of_shipped())
    spec = load_spec(tmp_path / "tiny.toml")
    cells = make_cells(spec)
    out = tmp_path / "out"
    done = sweep(spec, cells, out, Console(file=io.StringIO(), width=200), workers=2, processes=False)
    assert (done.cells, done.ran, done.failed) == (8, 8, [])

    rows = read_missions(out)
    strategies = ["cautious", "greedy", "keep_alive", "rolling"]
    assert sorted(zip(rows["profile"], rows["count"], rows["strategy"], strict=True)) == [
        *(("always_on", 1, s) for s in strategies), *(("hourly_wake", 28, s) for s in strategies)]
    assert (rows["days"] == 180 / 86400).all() and rows["alive"].all()  # 3 minutes: nobody empties
    sleepers = rows[rows["profile"] == "hourly_wake"]
    assert (sleepers["samples_scheduled"] > 0).all()
    assert (sleepers["samples_taken"] <= sleepers["samples_scheduled"]).all()

    table = capacity_table(rows)
    assert list(table["largest kept alive"]) == ["1"] * 4 + ["28"] * 4
    assert list(table["seeds kept"]) == ["1/1"] * 8
    assert list(zip(table["profile"], table["strategy"], strict=True)) == [
        *(("always_on", s) for s in strategies), *(("hourly_wake", s) for s in strategies)]

    figure = tmp_path / "capacity.png"
    assert main([str(out), "--figure", str(figure)]) == 0
    assert figure.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and figure.stat().st_size > 10_000
    assert main([str(tmp_path / "nothing")]) == 2  # no sweep there: one line, exit 2
    frame = pd.read_parquet(out / "results.parquet")
    assert set(frame["fleet.count"]) == {1, 28} and set(frame["fleet.profile"]) == {"always_on", "hourly_wake"}
    assert set(frame["platform"]) == {"event"}

    # The same missions again on the other platform: each beside its own (--against).
    lockstep = tmp_path / "lockstep.toml"
    lockstep.write_text(tiny_of_shipped().replace('platform = "event"', 'platform = "lockstep"').replace(
        'strategies = ["cautious", "greedy", "keep_alive", "rolling"]', 'strategies = ["cautious"]'))
    spec_l = load_spec(lockstep)
    sweep(spec_l, make_cells(spec_l), tmp_path / "lock", Console(file=io.StringIO(), width=200), workers=1,
          processes=False)
    table_l = agreement(rows, read_missions(tmp_path / "lock"))
    assert len(table_l) == 2 and (table_l["alive L"] == table_l["alive E"]).all()
    assert (table_l["uptime_avg L"] - table_l["uptime_avg E"]).abs().max() < 0.5


def test_the_largest_fleet_kept_alive_is_the_largest_size_nine_seeds_in_ten_kept() -> None:
    def mission(count: int, seed: int, alive: bool, strategy: str = "keep_alive") -> dict[str, object]:
        return {"profile": "always_on", "count": count, "strategy": strategy, "seed": seed, "alive": alive,
                "depleted": 0 if alive else 1, "uptime_avg": 80.0 + seed, "uptime_min": 70.0, "samples_taken": 5,
                "samples_scheduled": 10, "dockings_per_day": 8.0 * count, "rounds_per_day": 2.0 * count,
                "passed_wh_per_day": 30.0 * count, "home_h": 1.0, "days": 0.25, "sim_days": 7.5,
                "end": "mission time"}

    ten = range(1, 11)
    rows = pd.DataFrame([mission(2, s, True) for s in ten] + [mission(4, s, s != 3) for s in ten]
                        + [mission(6, s, s > 2) for s in ten]
                        + [mission(2, s, s != 1, "cautious") for s in ten[:5]] + [mission(4, 1, False, "cautious")])
    table = capacity_table(rows).set_index("strategy")
    assert table.loc["keep_alive", "largest kept alive"] == "4"  # 9 of 10 at 4; 6 lost two seeds
    assert table.loc["keep_alive", "seeds kept"] == "9/10"
    assert table.loc["keep_alive", "dockings / day"] == 32.0 and table.loc["keep_alive", "Wh passed / day"] == 120.0
    assert table.loc["keep_alive", "samples taken %"] == 50.0
    assert table.loc["keep_alive", "uptime avg %"] == "85.5 ± 3.0"
    assert table.loc["cautious", "largest kept alive"] == "< 2"  # 4 of 5 seeds is not 9 in 10
    assert table.loc["cautious", "sizes swept"] == "2 4"


def test_a_mission_ended_early_kept_no_one_alive() -> None:
    from gcs.sweep.capacity import mission_row

    result = {"mussels": [{"state_s": {"depleted": 0.0}, "dockings": []}], "duration_s": 86400.0, "apads": [{}],
              "uptime": {"avg": 97.0, "min": 95.0}, "cycles": 3, "theta": 30.0, "end_reason": "aPad battery"}
    record = {"result": result, "values": {"fleet.count": 1}, "strategy": "rolling", "seed": 1}
    assert not mission_row(record)["alive"]
    result["end_reason"] = "mission time"
    assert mission_row(record)["alive"]
