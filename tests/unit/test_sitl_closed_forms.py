"""A busy aPad's hull in closed form on the ideal link (`apad_sitl.cruise`, `apad_sitl.latch_hold`) against stepping.

Two real SITL aPads run the same GCS script over real MAVLink bytes (`memory_pair`) on a virtual
clock, one in lockstep's mode (every tick stepped) and one on the ideal link (`ideal_link=True`): a
Go To of 60 m, a Dock of an aMussel beside the point reached, an Undock, and a Go To replaced by
another mid-cruise. Each primitive ends on the same tick, the hull, battery and energy counters end
where stepping leaves them to float noise, the positions reported while cruising are lockstep's at
the same instants, and the ideal-link aPad stepped a small part of the ticks.
"""

from __future__ import annotations

from dataclasses import astuple, dataclass, field, replace
from typing import Any

import pytest
from testkit import command_bytes, go_to_bytes

from apad_sitl.cruise import Cruise
from apad_sitl.endpoint import SitlVehicle
from apad_sitl.latch_hold import LatchHold
from apad_sitl.params import ApadParams
from apad_sitl.vehicle import VehicleState
from mavlink_dialect import MAV_CMD_APAD_DOCK, MAV_CMD_APAD_UNDOCK, Codec, mavlink, memory_pair
from missiontime import US_PER_S, Scheduler, VirtualClock
from mussel_sim.geo import LocalFrame
from mussel_sim.vocabulary import MusselState

HOME = (43.94, 15.44)
FRAME = LocalFrame(*HOME)
START = (10.0, -20.0)  # away from the home charger
FIRST = (58.0, 16.0)  # 60 m on: two minutes at 0.5 m/s
MUSSEL = (58.5, 16.0)  # within the dock's reach of the point held
SECOND, REPLACED = (10.0, 60.0), (-30.0, 16.0)  # a Go To, and the one that replaces it while it cruises
GO, DOCK_AT, UNDOCK_AT, SECOND_AT, REPLACE_AT, END_S = 1, 400, 500, 600, 640, 900
CRUISE = (10, 110)  # seconds of the first Go To's steady cruise, well inside it
GPI = mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT






def _mussel(fleet: Codec, now_us: int) -> bytes:
    lat, lon = FRAME.to_geodetic(*MUSSEL)
    return fleet.encode(mavlink.MAVLink_amussel_status_message(
        now_us, 7, round(float(lat) * 1e7), round(float(lon) * 1e7), 0.0, 0.5, 3700, int(MusselState.FLOATING), 1))


@dataclass
class Run:
    """What one aPad reported and when, where its hull was, how it ended and what its physics cost."""

    changes: list[tuple[int, str, tuple[Any, ...]]] = field(default_factory=list)  # primitive and slot changes
    positions: list[tuple[int, int, int, int, int, int]] = field(default_factory=list)  # GLOBAL_POSITION_INT
    hull: dict[int, tuple[float, ...]] = field(default_factory=dict)  # the hull at each reader instant
    ticks: dict[str, int] = field(default_factory=dict)  # physics ticks in each stretch
    end: tuple[Any, ...] = ()
    mid_cruise: tuple[bool, bool, bool, int] = (False, False, False, 0)  # parked cruising; then the physics task


def _run(ideal: bool) -> Run:
    apad_end, gcs_end = memory_pair()
    clock = VirtualClock(Scheduler())
    vehicle = SitlVehicle(apad_end, ApadParams(), *HOME, ideal_link=ideal)
    vehicle.state = VehicleState(x_m=START[0], y_m=START[1], battery_v=15.0)
    gcs, fleet = Codec(250, 190), Codec(251, 25)
    run = Run()
    marks: dict[int, int] = {}
    last: dict[tuple[str, int], tuple[Any, ...]] = {}

    def script(now_us: int) -> None:  # the GCS, before the aPad in each instant's order
        t = now_us // US_PER_S
        if now_us % US_PER_S:
            return
        marks[t] = vehicle.physics.ticks if vehicle.physics is not None else 0
        out = {GO: [go_to_bytes(gcs, FRAME, *FIRST)], DOCK_AT - 1: [_mussel(fleet, now_us)],
               DOCK_AT: [command_bytes(gcs, MAV_CMD_APAD_DOCK, 1, 7)],
               UNDOCK_AT: [command_bytes(gcs, MAV_CMD_APAD_UNDOCK, 1, 7)],
               SECOND_AT: [go_to_bytes(gcs, FRAME, *SECOND)],
               REPLACE_AT: [go_to_bytes(gcs, FRAME, *REPLACED)]}.get(t, [])
        for data in out:
            gcs_end.send(data)

    def reader(now_us: int) -> None:  # the GCS's ear, after the aPad in each instant's order
        for data in gcs_end.receive():
            for msg in gcs.decode(data):
                kind = msg.get_type()
                if kind == "PRIMITIVE_STATUS":
                    said: tuple[Any, ...] = (msg.primitive, msg.progress, msg.slot, msg.mussel_id, msg.target_lat,
                                             msg.target_lon)
                elif kind == "DOCK_SLOT_STATUS":
                    said = (msg.slot, msg.mussel_id, msg.latch, msg.charging)
                else:
                    if msg.get_msgId() == GPI:
                        run.positions.append((now_us, msg.lat, msg.lon, msg.vx, msg.vy, msg.hdg))
                    continue
                stream = (kind, msg.slot if kind == "DOCK_SLOT_STATUS" else 0)
                if last.get(stream) != said:
                    last[stream] = said
                    run.changes.append((msg.time_us, kind, said))  # stamped with the tick that made it
        run.hull[now_us] = astuple(vehicle.state)

    clock.scheduler.every(0.05, script, "gcs")
    vehicle.attach(clock.scheduler)
    clock.scheduler.every(0.25, reader, "gcs-ear")
    clock.sleep(REPLACE_AT - 0.05)
    cruising = isinstance(vehicle.apad.rest, Cruise) and vehicle.physics is not None and vehicle.physics.parked
    clock.sleep(0.06)  # the command replacing the Go To handled (at REPLACE_AT), no tick since
    physics = vehicle.physics
    assert physics is not None
    run.mid_cruise = (cruising, physics.parked, physics.task.active, physics.task.next_us)
    clock.sleep(END_S - REPLACE_AT - 0.01)
    run.end = (vehicle.state, vehicle.energy_counters, vehicle.primitive, vehicle.mode)
    run.ticks = {"cruise": marks[CRUISE[1]] - marks[CRUISE[0]], "dock": marks[DOCK_AT + 12] - marks[DOCK_AT],
                 "undock": marks[UNDOCK_AT + 7] - marks[UNDOCK_AT], "all": marks[END_S - 1]}
    vehicle.close()
    return run


@pytest.fixture(scope="module")
def runs() -> tuple[Run, Run]:
    return _run(False), _run(True)


def test_each_primitive_ends_on_the_tick_stepping_ends_it_and_the_hull_where_stepping_leaves_it(
        runs: tuple[Run, Run]) -> None:
    lockstep, ideal = runs
    assert ideal.changes == lockstep.changes  # every primitive's and slot's change, on the same tick
    kinds = [(said[0], said[1]) for _, kind, said in lockstep.changes if kind == "PRIMITIVE_STATUS"]
    # Idle; a Go To under way, done; a Dock, done; an Undock, done; a Go To, another (a new target), done
    assert kinds == [(0, 0), (1, 1), (1, 2), (3, 1), (3, 2), (4, 1), (4, 2), (1, 1), (1, 1), (1, 2)]
    latches = [said[2] for _, kind, said in lockstep.changes if kind == "DOCK_SLOT_STATUS" and said[0] == 1]
    assert latches == [0, 1, 2, 3, 0]  # open, closing, latched, releasing, open
    done = {said[0]: t for t, kind, said in lockstep.changes if kind == "PRIMITIVE_STATUS" and said[1] == 2}
    assert done[3] - DOCK_AT * US_PER_S == 10 * US_PER_S + US_PER_S // 10  # the latch closed 10 s after the tick
    state, energy, primitive, mode = ideal.end
    reference = lockstep.end
    assert (primitive, mode) == reference[2:]  # the latch timers to the bit
    assert astuple(state) == pytest.approx(astuple(reference[0]), rel=0.0, abs=1e-9)  # position m, battery V
    assert astuple(energy) == pytest.approx(astuple(reference[1]), rel=0.0, abs=1e-9)  # Wh
    assert state.battery_v < 15.0 - 0.05  # it drained (the hull's thrust and hotel load)


def test_the_hull_while_cruising_and_the_positions_reported_are_lockstep_s(runs: tuple[Run, Run]) -> None:
    lockstep, ideal = runs
    assert ideal.hull.keys() == lockstep.hull.keys()
    for t, hull in ideal.hull.items():
        assert hull == pytest.approx(lockstep.hull[t], rel=0.0, abs=1e-9), t / US_PER_S
    lo, hi = CRUISE[0] * US_PER_S, CRUISE[1] * US_PER_S
    cruising = [p for p in ideal.positions if lo <= p[0] < hi]
    assert cruising == [p for p in lockstep.positions if lo <= p[0] < hi]  # every report, at its instant
    assert len(cruising) == (CRUISE[1] - CRUISE[0]) * 4  # the stream's 4 Hz: it moves, so each one is news


def test_the_ideal_link_steps_a_small_part_of_the_busy_ticks(runs: tuple[Run, Run]) -> None:
    lockstep, ideal = runs
    print(f"\nphysics ticks: lockstep {lockstep.ticks}, ideal link {ideal.ticks}")
    assert lockstep.ticks["cruise"] == 1_000 and ideal.ticks["cruise"] <= 2  # 100 s cruising: a closed form
    assert lockstep.ticks["dock"] >= 100 and ideal.ticks["dock"] <= 6  # the latch closing: a closed form
    assert lockstep.ticks["undock"] >= 50 and ideal.ticks["undock"] <= 6
    assert ideal.ticks["all"] * 3 < lockstep.ticks["all"]


def test_a_command_mid_cruise_ends_the_closed_form_at_once(runs: tuple[Run, Run]) -> None:
    _, ideal = runs
    was_cruising, parked, active, next_us = ideal.mid_cruise
    assert was_cruising  # the second Go To cruised, its physics parked
    assert not parked and active  # the new Go To ended it as it was handled:
    assert next_us == REPLACE_AT * US_PER_S + US_PER_S // 10  # ticking again from the next tick


def test_a_latch_hold_takes_the_timers_as_stepping_takes_them() -> None:
    from apad_sitl import primitives as prim
    from apad_sitl.energy_counters import EnergyCounters
    from apad_sitl.primitives import MusselFix
    from apad_sitl.rest import Rest

    params = ApadParams(dock_time_s=7.3)
    fixes = {7: MusselFix(0.5, 0.0)}
    stepped, _ = prim.dock(prim.PrimitiveState(), 2, 7, 0.0, 0.0, fixes, params)
    hold = LatchHold(Rest(VehicleState(), params, 0.1), stepped, (fixes[7],))
    n = 0
    while True:
        after = prim.step(stepped, 0.0, 0.0, fixes, params, 0.1)
        if after.progress != stepped.progress:
            break
        stepped, n = after, n + 1
    assert hold.limit == n and 70 < n < 75  # 7.3 s in steps of 0.1 s (as the floats fall)
    assert hold.take(100, EnergyCounters()) == n and hold.primitive() == stepped  # to the bit


@pytest.mark.parametrize("kind", ["goto", "dock"])
def test_a_settling_hull_is_where_stepping_takes_it_step_by_step(kind: str) -> None:
    """The closed form of the last metre (`apad_sitl.settling`) against `vehicle.step` itself, every step."""
    from apad_sitl import primitives as prim
    from apad_sitl import settling
    from apad_sitl import vehicle as veh
    from apad_sitl.latch_hold import closing_fixes
    from apad_sitl.primitives import MusselFix

    params, dt_s = ApadParams(), 0.1
    fixes = {7: MusselFix(20.3, 9.9)}
    primitive = prim.go_to(prim.PrimitiveState(), 20.0, 10.0)
    before = VehicleState(x_m=19.94, y_m=10.04, vx_mps=0.03, vy_mps=-0.02, water_vx_mps=0.03, water_vy_mps=-0.02,
                          heading_rad=2.0, battery_v=14.0, distance_travelled_m=100.0)
    if kind == "dock":  # the latch closes as the hull settles
        primitive, _ = prim.dock(replace(primitive, progress=prim.Progress.DONE), 1, 7, 19.94, 10.04, fixes, params)
    state = veh.step(before, prim.velocity_setpoint(primitive, before, params), params, (0.0, 0.0), dt_s)
    stepped = prim.step(primitive, state.x_m, state.y_m, fixes, params, dt_s)
    found = settling.found(before, state, stepped, params, (0.0, 0.0), fixes, True, dt_s, closing_fixes(stepped, fixes))
    assert found is not None
    limit = found.limit
    print(f"\n{kind}: {limit} steps in closed form")
    assert limit == 98 if kind == "dock" else limit > 300  # a dock: up to the latch (10 s); else to 2e-9 m
    primitive = stepped
    for n in range(1, limit + 1):
        state = veh.step(state, prim.velocity_setpoint(primitive, state, params), params, (0.0, 0.0), dt_s)
        primitive = prim.step(primitive, state.x_m, state.y_m, fixes, params, dt_s)
        found.steps = n
        assert astuple(found.state()) == pytest.approx(astuple(state), rel=1e-9, abs=1e-12), n
        assert found.primitive() == primitive  # the latch timer to the bit
    if kind == "dock":  # the step after next latches: the closed form stopped short of it, a step to spare
        progress = []
        for _ in range(2):
            state = veh.step(state, prim.velocity_setpoint(primitive, state, params), params, (0.0, 0.0), dt_s)
            primitive = prim.step(primitive, state.x_m, state.y_m, fixes, params, dt_s)
            progress.append(primitive.progress)
        assert progress == [prim.Progress.IN_PROGRESS, prim.Progress.DONE]


@pytest.mark.parametrize("current", [(0.0, 0.0), (0.06, 0.08), (0.08, -0.06)], ids=["slack", "along", "across"])
def test_a_cruise_is_where_stepping_takes_it_and_none_is_found_across_a_current(current: tuple[float, float]) -> None:
    """A Go To's cruise (`apad_sitl.cruise`) against `vehicle.step` itself, every step; a current across the
    track turns the setpoint as the hull goes (no steady cruise: stepped)."""
    from apad_sitl import cruise
    from apad_sitl import primitives as prim
    from apad_sitl import vehicle as veh

    params, dt_s = ApadParams(), 0.1
    primitive = prim.go_to(prim.PrimitiveState(), 60.0, 80.0)  # along (0.6, 0.8) from the origin
    state, found = VehicleState(battery_v=15.0), None
    for _ in range(300):  # accelerating, then steady
        before = state
        state = veh.step(before, prim.velocity_setpoint(primitive, before, params), params, current, dt_s)
        assert prim.step(primitive, state.x_m, state.y_m, {}, params, dt_s) is primitive
        found = found or cruise.found(before, state, primitive, params, dt_s)
        if found is not None:
            break
    if current == (0.08, -0.06):
        assert found is None
        return
    assert found is not None and found.limit > 1_000
    for n in range(1, found.limit + 1):
        state = veh.step(state, prim.velocity_setpoint(primitive, state, params), params, current, dt_s)
        if n % 97 == 0 or n == found.limit:
            assert astuple(found.after(n)) == pytest.approx(astuple(state), rel=1e-12, abs=1e-9), n
    assert prim.step(primitive, state.x_m, state.y_m, {}, params, dt_s).progress == prim.Progress.IN_PROGRESS
