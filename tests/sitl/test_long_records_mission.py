"""A real lockstep mission of several simulated days (pool12, 10 min at theta 600: a day is 144 s):
its per-day figures against what its own per-step records say, its shares of the time run, and a
report read from traces.npz against the same report replayed from the GCS log."""

from __future__ import annotations

import io
import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from rich.console import Console

import vil
from gcs.cli.tables import time_table
from gcs.mission.headless import run_mission
from gcs.records import playback
from gcs.report.load import load_run
from gcs.report.run_data import load_replayed_run
from gcs.results.run_result import RunResult
from gcs.scenario.reader import load_scenario
from mussel_sim.report_policy import STATUS_KEEPALIVE_S
from mussel_sim.vocabulary import MusselState

pytestmark = pytest.mark.sitl

DURATION_S, THETA = 600.0, 600.0
DAY_S = 86_400.0 / THETA  # 144 s


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> tuple[RunResult, Path]:
    out = tmp_path_factory.mktemp("days") / "pool12-days"
    result = run_mission(load_scenario("pool12").with_overrides(duration_s=DURATION_S, theta=THETA), out)
    return result, out


def test_per_day_figures_are_the_steps_of_each_day(run: tuple[RunResult, Path]) -> None:
    result, out = run
    z = np.load(out / "traces.npz")
    t_s = z["step_time_us"] / 1e6
    assert result.sim_day_s == DAY_S and len(result.days) == int(np.ceil(t_s[-1] / DAY_S)) == 5
    day = np.ceil(t_s / DAY_S).astype(int)  # a step ending at t counts in day ceil(t / 144 s)
    assert z["battery_steps"].size == t_s.size  # 600 rows: the traces are whole, every step's state is here
    alive = np.count_nonzero(z["battery_state"] != MusselState.DEPLETED, axis=1)
    n = z["ids"].size
    for row in result.days:
        mine = day == row["day"]
        assert row["uptime_pct"] == pytest.approx(100 * z["active_count"][mine].mean() / n, abs=1e-4)
        assert row["alive"] == alive[mine][-1]
        assert (row["from_s"], row["to_s"]) == ((row["day"] - 1) * DAY_S, min(row["day"] * DAY_S, t_s[-1]))
    first = [m.first_depleted_s for m in result.mussels if m.first_depleted_s is not None]
    assert sum(r["depleted"] for r in result.days) == len(first)
    for m_first in first:  # each first depletion in the day its step ended in
        assert result.days[int(np.ceil(m_first / DAY_S)) - 1]["depleted"] >= 1
    # Per aPad: the dockings that began each day, and the energy per day adding up to the aPad's counter.
    docks = [d["t_s"] for m in result.mussels for d in m.dockings]
    assert sum(r["charges"]["1"] for r in result.days) == len(docks) > 0
    for row in result.days:
        assert row["charges"]["1"] == sum(1 for t in docks if (row["day"] - 1) * DAY_S <= t < row["day"] * DAY_S)
    passed = sum(r["passed_wh"]["1"] for r in result.days)
    assert passed == pytest.approx(result.apads[0]["passed_wh"], abs=0.01) and passed > 0
    assert json.loads((out / "result.json").read_text())["days"] == result.days
    days = vil.load(out).days  # the Python API's table of them
    assert list(days.index) == [1, 2, 3, 4, 5] and list(days["charges_1"]) == [r["charges"]["1"] for r in result.days]
    assert days["uptime_pct"].tolist() == [r["uptime_pct"] for r in result.days]


def test_state_shares_sum_to_the_time_run(run: tuple[RunResult, Path]) -> None:
    result, out = run
    run_s = np.load(out / "traces.npz")["step_time_us"][-1] / 1e6
    for m in result.mussels:
        assert sum(m.state_s.values()) == pytest.approx(run_s, abs=1e-3)
    table = time_table([result])
    assert table is not None
    text = io.StringIO()
    Console(file=text, width=200).print(table)
    row = next(line for line in text.getvalue().splitlines() if line.strip().startswith("pool12 cautious"))
    active, docked, depleted = (float(x) for x in row.split()[3:6])  # "pool12 cautious s1" then the shares
    moving = ("surfacing", "floating", "sinking")
    rest = 100 * sum(m.state_s[s] for m in result.mussels for s in moving) / (run_s * len(result.mussels))
    assert active + docked + depleted + rest == pytest.approx(100.0, abs=0.2)  # and the way up or down
    a = result.apads[0]
    assert a["travelling_share"] + a["docking_share"] + a["holding_share"] == pytest.approx(1.0, abs=2e-4)


def test_a_report_from_traces_shows_what_the_replay_shows(run: tuple[RunResult, Path]) -> None:
    _, out = run
    traced, replayed = load_run(out), load_replayed_run(out)
    assert traced.indices.source == "result.json" and traced.t_s.size == 600
    with np.load(out / "traces.npz") as z:
        assert int(z["start_us"]) == 0  # the recorder's own start, not one guessed from the first step
    assert traced.t_s[0] == 1.0 and traced.end_s == DURATION_S
    rows = np.searchsorted(replayed.t_s, traced.t_s)  # the replay samples every second from 0
    np.testing.assert_array_equal(replayed.t_s[rows], traced.t_s)
    # The fleet reports by exception: every aMussel at each keep-alive window's start, one whose state
    # changed at once. So the replay (the GCS's log: what it heard) has every state when it happened, and
    # every battery at each window's start; between, the battery as last heard.
    window = traced.t_s % STATUS_KEEPALIVE_S == 0
    assert window.sum() == 120
    np.testing.assert_array_equal(replayed.battery[rows][window], traced.battery[window])
    np.testing.assert_array_equal(replayed.state[rows], traced.state)
    np.testing.assert_allclose(replayed.cost_m[rows], traced.cost_m, atol=1e-6)
    where = ("start_lat_deg", "start_lon_deg", "end_lat_deg", "end_lon_deg")
    for m, r in zip(traced.mussels, replayed.mussels, strict=True):
        # The model's own positions, the replay's as last heard (MAVLink's 1e-7 degree steps; a drift since)
        assert replace(m, start_lat_deg=0.0, start_lon_deg=0.0, end_lat_deg=0.0, end_lon_deg=0.0) == \
            replace(r, start_lat_deg=0.0, start_lon_deg=0.0, end_lat_deg=0.0, end_lon_deg=0.0)
        np.testing.assert_allclose([getattr(m, k) for k in where], [getattr(r, k) for k in where], atol=2e-6)
    assert traced.origin == replayed.origin and traced.end_reason == replayed.end_reason
    a, b = traced.tracks[0], replayed.tracks[0]
    common = np.intersect1d(a.t_s, b.t_s)
    assert common.size >= 590
    np.testing.assert_array_equal(a.lat_deg[np.isin(a.t_s, common)], b.lat_deg[np.isin(b.t_s, common)])


def test_a_replay_keeps_a_bounded_number_of_snapshots(run: tuple[RunResult, Path],
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    _, out = run
    assert [playback.sample_period_s(s) for s in (600.0, 20_000.0, 20_001.0, 7 * 86_400.0)] == [1.0, 1.0, 2.0, 31.0]
    whole = playback.load_replay(out)
    assert len(whole.frames) == 602  # one a second from 0 to 600 s, and the end
    monkeypatch.setattr(playback, "MAX_FRAMES", 100)  # as a week's run would be sampled: coarser, bounded
    thin = playback.load_replay(out)
    times = np.array([f.t_s for f in thin.frames[:-1]])
    assert len(thin.frames) <= 102 and np.all(np.diff(times) == 6.0)
    for f in thin.frames[:-1:10]:  # each snapshot is the whole replay's at the same instant
        same = whole.at(f.t_s)
        np.testing.assert_array_equal(f.battery_frac, same.battery_frac)
        np.testing.assert_array_equal(f.state, same.state)
