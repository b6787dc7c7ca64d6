"""Where a run's time went (issue 13): per-state seconds of every aMussel, the aPad's shares, the
sinking-counts-active option, the route re-check before each leg, and a depleted aMussel reported
where it is. Real headless runs (SITL aPad, fleet, GCS over MAVLink bytes) and the real fleet model."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from testkit import MISSIONS, read_jsonl, scenario_variant

from gcs.mission.headless import run_mission
from gcs.results.accounting import account
from gcs.results.run_result import RunResult
from gcs.scenario.reader import load_scenario
from mussel_sim.battery import DISCHARGE_ACTIVE_PER_MIN
from mussel_sim.fleet import step
from mussel_sim.fleet_state import ACTIVE, FLOATING, FleetInputs, FleetParams, state_from_arrays
from mussel_sim.geo import LocalFrame
from mussel_sim.startconfig import load_start_config, save_start_config
from mussel_sim.vocabulary import MusselState

pytestmark = pytest.mark.sitl

SHORT_S = 600.0
PER_S = DISCHARGE_ACTIVE_PER_MIN * 30 / 60  # battery an active aMussel loses per mission second at theta 30


def pool12(sinking_counts_active: bool, out_dir: Path | None = None) -> RunResult:
    s = load_scenario("pool12").with_overrides(duration_s=SHORT_S)
    s = replace(s, mission=replace(s.mission, sinking_counts_active=sinking_counts_active))
    return run_mission(s, out_dir)


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> tuple[RunResult, RunResult]:
    """pool12 cautious for 10 min, sinking counted as active (written to a folder) and not."""
    return pool12(True, tmp_path_factory.mktemp("pool12")), pool12(False)


def test_per_state_seconds_sum_to_the_mission_time_for_every_amussel(runs: tuple[RunResult, RunResult]) -> None:
    r, _ = runs
    names = [s.name.lower() for s in MusselState]
    for m in r.mussels:
        assert list(m.state_s) == names
        assert sum(m.state_s.values()) == r.duration_s, m.id
        # Eq. (3) counts ACTIVE and (the default, as in the paper) SINKING steps.
        assert m.uptime_pct == pytest.approx(100.0 * (m.state_s["active"] + m.state_s["sinking"]) / r.duration_s,
                                             abs=1e-4)
        assert (m.first_depleted_s is None) == (m.state_s["depleted"] == 0.0), m.id
    assert r.cycles >= 1 and any(m.state_s["docked"] > 0 and m.state_s["sinking"] > 0 for m in r.mussels)
    (apad,) = r.apads
    shares = [apad["travelling_share"], apad["docking_share"], apad["holding_share"]]
    assert sum(shares) == pytest.approx(1.0, abs=2e-4) and min(shares) > 0.0
    # The aPad travelled for about the time its odometer needs at its cruise speed.
    assert apad["travelling_share"] * r.duration_s == pytest.approx(r.travelled_m / 0.5, rel=0.25)

    traces = np.load(Path(r.out_dir) / "traces.npz")
    assert list(traces["state_names"]) == names
    assert traces["state_s"].shape == (12, len(names))
    np.testing.assert_array_equal(traces["state_s"].sum(axis=1), np.full(12, r.duration_s))
    np.testing.assert_array_equal(traces["state_s"][:, 0], [m.state_s["active"] for m in r.mussels])
    np.testing.assert_array_equal(traces["apad_ids"], [1])
    assert traces["apad_activity_s"].sum() == pytest.approx(r.duration_s)


def test_sinking_counts_as_active_unless_the_scenario_says_otherwise(runs: tuple[RunResult, RunResult]) -> None:
    counted, not_counted = runs
    assert counted.cost_m == not_counted.cost_m and counted.cycles == not_counted.cycles
    sank = 0.0
    for a, b in zip(counted.mussels, not_counted.mussels, strict=True):
        assert a.state_s == b.state_s  # the same run: only what counts as uptime differs
        assert a.uptime_pct - b.uptime_pct == pytest.approx(100.0 * a.state_s["sinking"] / SHORT_S, abs=1e-3)
        sank += a.state_s["sinking"]
    assert sank > 0
    assert counted.active_avg - not_counted.active_avg == pytest.approx(sank / SHORT_S, abs=1e-3)


def test_first_depletion_is_when_the_battery_gives_out() -> None:
    """No charging: each aMussel depletes in the first step that ends with u <= 0 (eq. 1)."""
    s = load_scenario("pool12").with_overrides(strategy="none", duration_s=300.0, theta=240.0)
    r = run_mission(s)
    per_step = DISCHARGE_ACTIVE_PER_MIN * 240.0 / 60.0
    for m in r.mussels:
        assert m.first_depleted_s == pytest.approx(math.ceil(m.start_battery / per_step), abs=1.0), m.id
        assert m.state_s["depleted"] == 300.0 - m.first_depleted_s + 1.0  # that step counts as depleted
        assert m.state_s["active"] + m.state_s["depleted"] == 300.0


def test_the_route_is_rechecked_before_each_leg_and_a_depleted_amussel_skipped(tmp_path: Path) -> None:
    """Greedy plans [8, 1] (8 is nearer the aPad). aMussel 1 has 140 s of battery: enough for the
    slowed aPad (0.25 m/s, 20 m away) to dock it when planned, gone by the time the aPad has
    docked 8 (a 90 s latch). The aPad must not go to it and wait out the surfacing timeout: it
    skips it before the leg, with a `skipped` event."""
    start = load_start_config(MISSIONS / "starts" / "pool12.geojson")
    battery = np.full(start.n, 0.99)
    battery[start.ids == 8] = 0.5
    battery[start.ids == 1] = 140 * PER_S
    path = tmp_path / "start.geojson"
    save_start_config(path, replace(start, battery_frac=battery))
    variant = scenario_variant("pool12", tmp_path / "recheck.toml", {
        f"{MISSIONS}/starts/pool12.geojson": str(path), "min_pool = 4": "min_pool = 2",
        'collect_strategy = "cautious"': 'collect_strategy = "greedy"', "speed_mps = 0.5": "speed_mps = 0.25",
        "dock_time_s = 10": "dock_time_s = 90",
        'duration = "40m"': 'duration = "8min"'})
    out = tmp_path / "run"
    r = run_mission(load_scenario(variant), out)
    events = read_jsonl(out / "events.jsonl")
    plans = [e for e in events if e["event"] == "plan_collection"]
    assert plans[0]["route"] == [8, 1]
    skipped = [e for e in events if e["event"] == "skipped" and e["mussel"] == 1]
    assert skipped and skipped[0]["why"] == "depleted"
    docked_8 = next(e["t_s"] for e in events if e["event"] == "docked" and e["mussel"] == 8)
    assert skipped[0]["t_s"] >= docked_8  # checked again before the second leg
    assert not any(e["event"] == "call_up" and e["mussel"] == 1 for e in events)
    assert not any(e.get("why") == "did not surface" for e in events)
    first = {m.id: m for m in r.mussels}[1].first_depleted_s
    assert first is not None and first == pytest.approx(140.0, abs=2.0)
    assert {w["id"]: w["where"] for w in r.whereabouts}[1] == "seabed"


def _frame_and_homes(x_m: float) -> tuple[LocalFrame, dict[int, tuple[float, float]]]:
    frame = LocalFrame(43.94, 15.44)
    lat, lon = frame.to_geodetic(np.array([x_m]), np.array([0.0]))
    return frame, {1: (float(lat[0]), float(lon[0]))}


def test_an_amussel_that_depletes_floating_or_rising_is_reported_where_it_is() -> None:
    """The real fleet model: one aMussel floating with 3 s of battery, one called up with 10 s of
    battery for a 20 s rise. Both deplete where they are; the account says so, not "seabed"."""
    p = FleetParams(drift_half_width_m=0.0)
    rng = np.random.default_rng(0)
    for start_state, battery_s, want, depth in ((FLOATING, 3, "surface", 0.0), (ACTIVE, 10, "water", None)):
        s = state_from_arrays([1], [5.0], [0.0], [battery_s * PER_S], p, state=[start_state])
        inputs = FleetInputs.make(apads={1: (0.0, 0.0)}, surface=[1] if start_state == ACTIVE else [])
        for _ in range(15):
            s, _ = step(s, inputs, p, rng, 1.0)
            inputs = FleetInputs()
        assert s.state[0] == MusselState.DEPLETED
        assert 0.0 <= s.depth_m[0] < p.seabed_depth_m and (depth is None or s.depth_m[0] == depth)
        frame, homes = _frame_and_homes(5.0)
        (where,) = account(s, frame, homes, {}, p.seabed_depth_m)
        assert (where.where, where.lost) == (want, False)
        assert where.detail.startswith("depleted at the surface" if want == "surface" else "depleted 1.")
