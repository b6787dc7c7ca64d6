"""Real aMussels beside simulated ones: a separate process plays real agents reporting sparsely over
UDP to the GCS's bridge; the planner serves both; an id that is both real and simulated is refused."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from testkit import free_udp_port, scenario_variant

from gcs.belief.duty import Duty
from gcs.cli.main import main
from gcs.loop.control import LoopControl
from gcs.mission.world import LinkOptions, build_world
from gcs.scenario.reader import load_scenario
from missiontime import PacedClock
from mussel_sim.battery import discharge_profile
from mussel_sim.vocabulary import MusselState

pytestmark = pytest.mark.sitl
ROOT = Path(__file__).resolve().parents[2]
REAL = {101: (43.94002, 15.43990), 102: (43.93998, 15.43995)}  # in the pool, near the aPad's home


def _scenario(tmp_path: Path, extra: str) -> Path:
    return scenario_variant("pool12", tmp_path / "pool12_real.toml",
                            {"[fleet]\n": f"[fleet]\n{extra}\n", 'duration = "40m"': 'duration = "15m"'})



def test_real_amussels_on_the_bridge_are_served_beside_the_simulated_fleet(tmp_path: Path) -> None:
    scenario = load_scenario(_scenario(tmp_path, "real_ids = [101, 102]"))
    port = free_udp_port()
    world = build_world(scenario, PacedClock(20.0), tmp_path / "run", LinkOptions(bridge=f"udp:127.0.0.1:{port}"))
    mussels = [f"--mussel={m}:{lat},{lon}" for m, (lat, lon) in REAL.items()] + ["--mussel=5:43.94,15.44"]
    agent = subprocess.Popen([sys.executable, str(ROOT / "tests/sitl/real_mussel_agent.py"), "--gcs",
                              f"127.0.0.1:{port}", *mussels, "--duration", "60"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        world.api.wait_apad(timeout_s=10.0)
        world.request_telemetry()
        while not all(m in world.api.mussels for m in REAL):  # the agent's first sparse reports
            assert world.clock.time() < 300.0 and agent.poll() is None, "no report from the real aMussels"
            world.clock.sleep(1.0)
        control = LoopControl()
        loop = world.mission_loop(control)
        # Stop once a real aMussel is on board (or at the mission's end).
        control.before_wait = lambda: any(m in REAL for _, m in loop.status.dockings)
        loop.run()
        assert world.real is not None
        later_us = world.clock.now_us + 60_000_000  # a minute of mission time without a report
        off_slot, on_slot = world.real.estimate(101, later_us), world.real.estimate(101, later_us, on_slot=True)
        # A sleep order sent to a real aMussel: the planner's estimate runs on the order's drain from then
        # on, from what it estimated when the order went (no jump at the order).
        order = Duty.of_order(3600.0, 60.0)
        sleeper = next(m for m in REAL if m not in loop.knows.docked().values())  # the one not on board
        sleeper_state = world.api.mussels[sleeper].state
        now_us = world.clock.now_us
        unordered = loop.knows.battery(sleeper)
        loop.book.ordered(sleeper, order)
        ordered_drain, believed = loop.knows.drain_per_min(sleeper), loop.knows.battery(sleeper)
        asleep = world.real.estimate(sleeper, later_us, drain_per_min=ordered_drain, anchor=(now_us, believed))
        from_report = world.real.estimate(sleeper, later_us, drain_per_min=ordered_drain)
        sleeper_off = world.real.estimate(sleeper, later_us)
        dropped = dict(world.link.dropped)
        table = world.api.mussels
        simulated_5 = table[5].simulated
    finally:
        world.close()
        agent.terminate()
        out, err = agent.communicate(timeout=10)
    docked = [m for _, m in loop.status.dockings]
    assert any(m in REAL for m in docked), f"no real aMussel docked: {docked}"
    route = set(loop.status.route)
    assert route & set(REAL) and route - set(REAL)  # one plan over real and simulated aMussels alike
    assert f"SURFACE {next(m for m in docked if m in REAL)}" in out.splitlines(), out + err
    # The bridge hears what is for real aMussels (their commands, the GCS alive), not the rest.
    heard = {line.split()[1] for line in out.splitlines() if line.startswith("HEARD ")}
    assert heard == {"HEARTBEAT", "AMUSSEL_COMMAND"}, heard
    # One fleet to the planner: the real ones got homes (where they were found) like the simulated.
    assert set(REAL) <= set(loop.homes) and len(loop.homes) == 12 + len(REAL)
    # The real one reporting a simulated aMussel's id was refused, never believed.
    assert dropped.get("AMUSSEL_STATUS.id_collision", 0) >= 1 and simulated_5
    # Between reports the GCS estimates by the fleet's models, and says how old its knowledge is:
    # 60 s of mission at theta 30 is 30 simulated minutes of eq. (1) off a slot, of eq. (2) on one.
    assert off_slot.age_s >= 60.0 and off_slot.reported_battery_frac == pytest.approx(0.3)
    drain = discharge_profile(scenario.fleet.discharge).rate_per_min * off_slot.age_s / 60.0 * scenario.mission.theta
    assert off_slot.battery_frac == pytest.approx(max(0.0, 0.3 - drain))
    assert on_slot.battery_frac > 0.3
    assert ordered_drain == order.rate_per_min < discharge_profile(scenario.fleet.discharge).rate_per_min
    assert believed == unordered and sleeper_state != MusselState.DOCKED
    slept_min = (later_us - now_us) / 60e6 * scenario.mission.theta  # the order's drain from the order on
    assert asleep.battery_frac == pytest.approx(max(0.0, believed - order.rate_per_min * slept_min))
    assert sleeper_off.battery_frac < asleep.battery_frac < from_report.battery_frac  # not back to the report


def test_an_id_both_real_and_simulated_is_refused_at_start(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    clash = _scenario(tmp_path, "real_ids = [101, 5]")
    assert main(["run", str(clash), "--out", str(tmp_path / "runs")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "fleet.real_ids: 5 also simulated" in err
    # Unless the scenario says the real one replaces the simulated one: then the simulated fleet is 11.
    replaced = load_scenario(_scenario(tmp_path, "real_ids = [101, 5]\nreal_replaces_simulated = true"))
    world = build_world(replaced, PacedClock(1000.0))
    try:
        assert 5 not in world.start.ids.tolist() and len(world.start.ids) == 11
    finally:
        world.close()
