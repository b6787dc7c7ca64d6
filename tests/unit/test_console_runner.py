"""The console's world-thread runner and model, without Textual."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from apad_sitl.vocabulary import Primitive
from gcs.console.canvas import BrailleCanvas
from gcs.console.runner import ConsoleConfig, ConsoleRunner, Hold, PacedClock, UndockMussel
from gcs.link import telemetry
from gcs.link.registry import VehicleRegistry
from gcs.records.events import Event
from gcs.scenario.reader import load_scenario
from gcs.view.model import MissionView
from gcs.view.snapshot import MarkerColour
from mavlink_dialect import Codec, mavlink
from mussel_sim.vocabulary import MusselState

POOL12 = Path(__file__).resolve().parents[2] / "missions" / "pool12.toml"


def _status(registry: VehicleRegistry, mussel_id: int, battery: float, state: MusselState) -> None:
    """One AMUSSEL_STATUS as the link hands it to the registry: real bytes, read once."""
    msg = Codec(251, 25).encode(mavlink.MAVLink_amussel_status_message(
        0, mussel_id, 439400000, 154400000, 3.0, battery, 4000, int(state), 1))
    (decoded,) = Codec(250, 190).decode(msg)
    record = telemetry.read(decoded)
    assert isinstance(record, telemetry.MusselView)
    registry.apply(251, record, 0)


def test_model_classes_uptime_and_copies() -> None:
    registry = VehicleRegistry()
    model = MissionView(registry, 1, 0.8, 60.0, "test", np.array([1, 2, 3, 4]))
    for mussel_id, battery, state in ((1, 0.9, MusselState.ACTIVE), (2, 0.5, MusselState.ACTIVE),
                                      (3, 0.0, MusselState.DEPLETED), (4, 0.7, MusselState.DOCKED)):
        _status(registry, mussel_id, battery, state)
    model.sample(0.0)
    _status(registry, 1, 0.9, MusselState.SURFACING)
    model.sample(1.0)
    snap = model.snapshot(1.0)
    assert list(snap.marker_classes()) == [MarkerColour.CHARGED, MarkerColour.CANDIDATE, MarkerColour.DEPLETED,
                                           MarkerColour.DOCKED]
    assert list(snap.uptime_pct) == [50.0, 100.0, 0.0, 0.0]
    assert list(snap.hist_active) == [2, 1]
    _status(registry, 2, 0.1, MusselState.ACTIVE)
    _status(registry, 9, 0.5, MusselState.ACTIVE)  # a newcomer grows the fleet
    assert snap.battery_frac[1] == 0.5 and snap.mussel_ids.size == 4  # the snapshot is a copy
    assert list(model.snapshot(2.0).mussel_ids) == [1, 2, 3, 4, 9]


def test_model_counts_sinking_as_the_results_do() -> None:
    """The console's uptime reads as result.json's: sinking after release counts unless the scenario says not."""
    for counts, expected in ((True, [100.0, 100.0]), (False, [100.0, 0.0])):
        registry = VehicleRegistry()
        model = MissionView(registry, 1, 0.8, 60.0, "test", np.array([1, 2]), sinking_counts_active=counts)
        _status(registry, 1, 0.9, MusselState.ACTIVE)
        _status(registry, 2, 0.9, MusselState.SINKING)
        model.sample(0.0)
        assert list(model.snapshot(0.0).uptime_pct) == expected


def test_model_counts_cycles_and_strategy_from_events() -> None:
    model = MissionView(VehicleRegistry(), 1, 0.8, 60.0, "test")
    for kind, fields in (("mission_start", {"strategy": "cautious"}), ("phase", {"phase": "idle wait"}),
                         ("strategy_switch", {"old": "cautious", "new": "greedy"}),
                         ("plan_redeployment", {"route": [1]}), ("phase", {"phase": "idle wait"}),
                         ("mission_end", {"reason": "mission time"})):
        model.event(Event(1.0, kind, fields))
    snap = model.snapshot(1.0)
    assert (snap.strategy, snap.cycles, snap.ended, snap.phase) == ("greedy", 1, "mission time", "idle wait")


def test_canvas_dots_lines_and_glyphs() -> None:
    canvas = BrailleCanvas(4, 2, ["#000000", "#ff0000"])
    canvas.polyline([0, 7], [0, 0], 1)
    canvas.glyphs([6.5], [6.0], "●", [1])
    canvas.dots([np.nan, 100.0], [0.0, 0.0], 1)  # skipped, not an error
    rows = [strip.text for strip in canvas.strips()]
    assert rows[0] == "⠉⠉⠉⠉" and rows[1] == "   ●"


def test_paced_clock_keeps_to_its_speed() -> None:
    wall = {"now_s": 50.0}
    waits: list[float] = []

    def wait(dt_s: float) -> None:
        waits.append(dt_s)
        wall["now_s"] += dt_s

    clock = PacedClock(speed=20.0, monotonic=lambda: wall["now_s"], wait=wait)
    clock.sleep(2.0)
    assert clock.time() == 2.0
    assert wall["now_s"] - 50.0 == pytest.approx(2.0 / 20.0)  # 2 s of mission time took 0.1 s of wall time
    assert len(waits) == 20  # in steps of 0.1 s of mission time, so a watcher sees it move


def test_a_paced_clock_started_late_keeps_its_pace_from_its_start() -> None:
    """A resumed mission's clock starts at the checkpoint's time and is paced from then, not from 0."""
    wall = {"now_s": 50.0}

    def wait(dt_s: float) -> None:
        wall["now_s"] += dt_s

    clock = PacedClock(speed=20.0, monotonic=lambda: wall["now_s"], wait=wait, start_us=600_000_000)
    assert clock.time() == 600.0
    clock.sleep(2.0)
    assert clock.time() == 602.0
    assert wall["now_s"] - 50.0 == pytest.approx(2.0 / 20.0)  # no 30 s wait to "catch up" with 600 s


@pytest.mark.sitl
def test_runner_serves_operator_commands_between_loop_waits() -> None:
    runner = ConsoleRunner(ConsoleConfig(load_scenario(POOL12), sitl="udp", speed=40.0))
    thread = threading.Thread(target=runner.run)
    thread.start()
    try:
        deadline = time.monotonic() + 15
        while not (runner.world and runner.world.vehicle and runner.world.vehicle.primitive.kind == Primitive.GOTO):
            assert time.monotonic() < deadline
            time.sleep(0.02)
        runner.submit(Hold())
        runner.submit(UndockMussel(5))  # not docked: refused with a reason, nothing sent
        while not (runner.snapshot and "refused: aMussel 5 is not docked" in runner.snapshot.notice):
            assert time.monotonic() < deadline
            time.sleep(0.02)
        vehicle = runner.world.vehicle
        assert vehicle.primitive.kind == Primitive.HOLD and runner.control.paused
        assert runner.snapshot.mode == "HOLD" and runner.snapshot.paused
    finally:
        runner.request_quit()
        thread.join(60)
    assert not thread.is_alive() and runner.error is None


def test_a_batch_of_statuses_takes_the_good_rows_and_counts_the_bad_ones_by_reason() -> None:
    from gcs.link.fleet_table import MusselBatch, MusselTable

    table = MusselTable()
    n = 6
    wire = {"mussel_id": np.array([1, 2, 3, 0, 5, 6]), "lat": np.full(n, 439400000), "lon": np.full(n, 154400000),
            "depth": np.array([3.0, np.nan, 3.0, 3.0, 3.0, 3.0]), "battery": np.array([0.5, 0.5, 1.5, 0.5, 0.5, 0.5]),
            "battery_voltage": 4000, "state": np.array([0, 0, 0, 0, 9, 2]), "simulated": 1, "time_us": 7}
    rejected = table.update_batch(MusselBatch.from_wire(wire))
    assert sorted(table) == [1, 6]  # the only rows with nothing wrong
    assert rejected == {"AMUSSEL_STATUS.battery_depth": 2, "AMUSSEL_STATUS.mussel_id": 1, "AMUSSEL_STATUS.state": 1}
    assert table[6].state == MusselState.FLOATING and table[6].time_us == 7


def test_a_status_from_beyond_int64_time_is_refused_not_an_overflow() -> None:
    from gcs.link.fleet_table import MusselBatch, MusselTable

    table = MusselTable()
    wire = {"mussel_id": np.array([1, 2], np.uint16), "lat": 439400000, "lon": 154400000, "depth": 3.0,
            "battery": 0.5, "battery_voltage": 4000, "state": 0, "simulated": 1,
            "time_us": np.array([7, 2**63], np.uint64)}  # what a hostile uint64 on the wire can hold
    assert table.update_batch(MusselBatch.from_wire(wire)) == {"AMUSSEL_STATUS.time_us": 1}
    assert list(table) == [1]


def test_a_real_aMussel_with_a_simulated_ones_id_is_refused_and_overwrites_nothing() -> None:
    from gcs.link.fleet_table import MusselBatch

    registry = VehicleRegistry()
    _status(registry, 3, 0.4, MusselState.ACTIVE)  # simulated (the helper's frames say simulated = 1)
    real = telemetry.MusselView(3, 0, 0, 1.0, 0.9, 4100, MusselState.FLOATING, False, 9)
    assert registry.apply(42, real, 0) == "AMUSSEL_STATUS.id_collision"
    assert registry.mussels[3].battery_frac == pytest.approx(0.4) and registry.mussels[3].simulated  # float32
    # and the other way round: the simulated fleet's batch does not overwrite a real node
    registry.apply(42, telemetry.MusselView(7, 0, 0, 1.0, 0.9, 4100, MusselState.ACTIVE, False, 9), 0)
    wire = {"mussel_id": np.array([7, 8]), "lat": 1, "lon": 1, "depth": 3.0, "battery": 0.5,
            "battery_voltage": 4000, "state": 0, "simulated": 1, "time_us": 1}
    assert registry.mussels.update_batch(MusselBatch.from_wire(wire)) == {"AMUSSEL_STATUS.id_collision": 1}
    assert registry.mussels[7].battery_frac == 0.9 and registry.mussels[8].simulated


def test_a_vehicle_that_answers_in_progress_forever_fails_the_command_at_the_bound() -> None:
    """A real link over real bytes: the far end says IN_PROGRESS every half second, and nothing more."""
    from gcs.link.command_protocol import IN_PROGRESS_MAX_S, CommandError
    from gcs.link.router import Link
    from mavlink_dialect import memory_pair
    from missiontime import VirtualClock

    clock = VirtualClock()
    gcs_end, far_end = memory_pair()
    link = Link(clock)
    link.add_transport(gcs_end)
    vehicle = Codec(1, 1)

    working_on: list[int] = []

    def in_progress(now_us: int) -> None:
        for data in far_end.receive():
            working_on.extend(m.command for m in vehicle.decode(data) if m.get_type() == "COMMAND_LONG")
        for command in working_on[-1:]:
            far_end.send(vehicle.encode(mavlink.MAVLink_command_ack_message(
                command, mavlink.MAV_RESULT_IN_PROGRESS, 0, 0, 250, 190)))

    clock.scheduler.every(0.5, in_progress, "stubborn vehicle")
    with pytest.raises(CommandError, match="IN_PROGRESS") as err:
        link.commands.send_long(1, mavlink.MAV_CMD_DO_SET_MODE, (1, 4))
    assert err.value.result == mavlink.MAV_RESULT_IN_PROGRESS
    assert IN_PROGRESS_MAX_S <= clock.time() < IN_PROGRESS_MAX_S + 2.0  # bounded, not forever


POOL12X2 = POOL12.with_name("pool12x2.toml")


def test_the_model_follows_every_apad_and_shows_the_selected_one() -> None:
    registry = VehicleRegistry()
    model = MissionView(registry, 1, 0.8, 60.0, "test", np.array([1, 2, 3, 4]), apad_ids=(1, 2))
    model.set_owner({1: 1, 2: 2, 3: 2, 4: 1})
    for apad, phase in ((1, "collect"), (2, "idle wait"), (2, "charging wait")):
        model.event(Event(1.0, "phase", {"apad": apad, "phase": phase}))
    model.event(Event(2.0, "mission_end", {"apad": 1, "reason": "apad battery"}))
    model.sample(0.0)
    snap = model.snapshot(2.0, selected=2)
    assert snap.selected == 2 and snap.phase == "charging wait" and snap.ended is None  # aPad 2 still runs
    assert [(a.system_id, a.phase, a.share, a.ended) for a in snap.apads] == [
        (1, "collect", (1, 4), "apad battery"), (2, "charging wait", (2, 3), None)]
    assert list(snap.owner) == [1, 2, 2, 1]
    assert snap.log[-1] == "00:02 aPad 1: mission ended: apad battery"
    model.event(Event(3.0, "mission_end", {"apad": 2, "reason": "operator stop"}))
    assert model.snapshot(3.0).ended == "apad battery" and model.snapshot(3.0).phase == "collect"  # aPad 1's


@pytest.mark.sitl
def test_a_swarm_runner_pauses_hands_the_strategy_to_and_stops_every_loop() -> None:
    runner = ConsoleRunner(ConsoleConfig(load_scenario(POOL12X2), sitl="memory", speed=40.0))
    thread = threading.Thread(target=runner.run)
    thread.start()

    def loop_events() -> list[Event]:
        assert runner.world is not None
        return [e for e in list(runner.world.events.events) if "apad" in e.fields and e.kind != "mission_end"]

    def until(condition: Callable[[], bool]) -> None:
        deadline = time.monotonic() + 20
        while not condition():
            assert time.monotonic() < deadline
            time.sleep(0.02)

    try:
        until(lambda: runner.world is not None and {e.fields["apad"] for e in loop_events()} == {1, 2})
        runner.set_paused(True)
        until(lambda: runner.snapshot is not None and runner.snapshot.paused)
        t0 = runner.snapshot.t_s
        until(lambda: runner.snapshot is not None and runner.snapshot.t_s > t0 + 10)  # every loop at a wait
        n, t1 = len(loop_events()), runner.snapshot.t_s
        until(lambda: runner.snapshot is not None and runner.snapshot.t_s > t1 + 30)
        assert len(loop_events()) == n  # neither loop did anything while paused
        other = "greedy" if runner.loops[1].status.strategy != "greedy" else "cautious"
        runner.switch_strategy(other)
        runner.set_paused(False)
        until(lambda: all(runner._controls[a].strategy == other or runner.loops[a].status.strategy == other
                          for a in (1, 2)))  # each loop is handed it, and takes it at its next plan
        assert runner.snapshot is not None
    finally:
        runner.request_quit()
        thread.join(60)
    assert not thread.is_alive() and runner.error is None
    assert runner.world is not None
    ends = {e.fields["apad"]: e.fields["reason"] for e in runner.world.events.events if e.kind == "mission_end"}
    assert ends == {1: "operator stop", 2: "operator stop"}


def test_a_plan_is_one_line_in_the_console_log_not_its_phase_and_then_its_plan() -> None:
    model = MissionView(VehicleRegistry(), 1, 0.8, 60.0, "test", np.array([1, 2]))
    for kind, fields in (("phase", {"phase": "plan collection"}),
                         ("plan_collection", {"strategy": "cautious", "route": [2, 1]}),
                         ("phase", {"phase": "collect"}),
                         ("phase", {"phase": "plan redeployment"}),
                         ("plan_redeployment", {"strategy": "greedy", "route": [1, 2]})):
        model.event(Event(1.0, kind, fields))
    log = model.snapshot(1.0).log
    assert len(log) == 3 and not any("plan collection" in line or "plan redeployment" in line for line in log), log
