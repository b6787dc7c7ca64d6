"""Mission primitives of the aPad as a pure state machine, closed over the kinematic model."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace

import pytest

from apad_sitl import primitives as prim
from apad_sitl.params import ApadParams
from apad_sitl.primitives import IN_PROGRESS, MusselFix, PrimitiveState, Refusal
from apad_sitl.vehicle import VehicleState, step
from apad_sitl.vocabulary import Latch, Primitive, Progress

P = ApadParams()
DT = 0.1
NO_MUSSELS: Mapping[int, MusselFix] = {}


class Sim:
    """The physics loop of the endpoint, without MAVLink: controller -> vehicle -> primitives."""

    def __init__(self, current: tuple[float, float] = (0.0, 0.0), params: ApadParams = P) -> None:
        self.vehicle = VehicleState()
        self.prim = PrimitiveState()
        self.current = current
        self.params = params
        self.mussels: dict[int, MusselFix] = {}
        self.t_s = 0.0

    def tick(self) -> None:
        sp = prim.velocity_setpoint(self.prim, self.vehicle, self.params)
        self.vehicle = step(self.vehicle, sp, self.params, self.current, DT)
        self.prim = prim.step(self.prim, self.vehicle.x_m, self.vehicle.y_m, self.mussels, self.params, DT)
        self.t_s += DT

    def run(self, seconds: float) -> list[tuple[float, float]]:
        track = []
        for _ in range(round(seconds / DT)):
            self.tick()
            track.append((self.vehicle.x_m, self.vehicle.y_m))
        return track

    def run_until_done(self, limit_s: float = 600.0) -> float:
        start = self.t_s
        while self.prim.progress == IN_PROGRESS:
            assert self.t_s - start < limit_s, "primitive never finished"
            self.tick()
        return self.t_s - start

    def dock(self, slot: int, mussel_id: int) -> Refusal | None:
        self.prim, refusal = prim.dock(self.prim, slot, mussel_id, self.vehicle.x_m, self.vehicle.y_m,
                                       self.mussels, self.params)
        return refusal

    def undock(self, slot: int, expected: int = 0) -> Refusal | None:
        self.prim, refusal = prim.undock(self.prim, slot, expected, self.vehicle.x_m, self.vehicle.y_m, self.params)
        return refusal


def dist(a: tuple[float, float], b: tuple[float, float]) -> float:
    return math.hypot(a[0] - b[0], a[1] - b[1])


def test_in_progress_is_one_as_in_the_papers_listing() -> None:
    assert IN_PROGRESS == 1


@pytest.mark.parametrize("current", [(0.0, 0.0), (0.2, 0.0), (0.0, -0.2), (-0.14, 0.14)])
@pytest.mark.parametrize("radius_m", [1.0, 3.0])
def test_go_to_stops_within_the_victory_radius_and_holds_there(current: tuple[float, float], radius_m: float) -> None:
    sim = Sim(current)
    target = (40.0, -25.0)
    sim.prim = prim.go_to(sim.prim, *target, radius_m=radius_m)
    assert sim.prim.kind == Primitive.GOTO and sim.prim.progress == IN_PROGRESS
    sim.run_until_done()
    assert sim.prim.progress == Progress.DONE
    assert dist((sim.vehicle.x_m, sim.vehicle.y_m), target) <= radius_m
    track = sim.run(120.0)  # it holds the target: never leaves the radius, ends close to it
    assert max(dist(p, target) for p in track) <= radius_m
    assert dist(track[-1], target) <= 0.3
    assert sim.prim.progress == Progress.DONE


def test_go_to_in_still_water_does_not_overshoot() -> None:
    sim = Sim()
    sim.prim = prim.go_to(sim.prim, 30.0, 0.0)
    track = sim.run(120.0)
    assert max(x for x, _ in track) <= 30.0 + 1e-6
    assert track[-1][0] == pytest.approx(30.0, abs=0.01)


def test_go_to_speed_sets_the_travel_time() -> None:
    times = {}
    for speed in (0.25, 0.0):  # 0: SPEED_MAX
        sim = Sim()
        sim.prim = prim.go_to(sim.prim, 60.0, 0.0, speed_mps=speed)
        times[speed] = sim.run_until_done()
    assert times[0.0] == pytest.approx(59.0 / P.speed_max_mps + 2.0, abs=2.0)
    assert times[0.25] == pytest.approx(2.0 * times[0.0], rel=0.1)


def test_speed_max_is_read_at_run_time() -> None:
    sim = Sim()
    sim.prim = prim.go_to(sim.prim, 100.0, 0.0)
    sim.run(20.0)
    sim.params = replace(P, speed_max_mps=0.2)
    sim.run(10.0)
    assert sim.vehicle.ground_speed_mps == pytest.approx(0.2)


@pytest.mark.parametrize("heading_deg", [0, 45, 90, 180, 270])
def test_hold_keeps_within_a_metre_against_a_current(heading_deg: float) -> None:
    c = 0.2
    current = (c * math.sin(math.radians(heading_deg)), c * math.cos(math.radians(heading_deg)))
    sim = Sim(current)
    sim.prim = prim.hold(sim.prim, 0.0, 0.0)
    track = sim.run(600.0)
    assert max(dist(p, (0.0, 0.0)) for p in track) <= 1.0
    # Steady state of the PD against a steady current: c / (kp (1 + kd)) down-current.
    expected = c / (P.hold_kp_per_s * (1.0 + P.hold_kd))
    assert dist(track[-1], (0.0, 0.0)) == pytest.approx(expected, rel=0.01)
    assert sim.prim.progress == Progress.DONE


def test_idle_drifts_with_the_current() -> None:
    sim = Sim((0.1, 0.0))
    sim.run(50.0)
    assert sim.vehicle.x_m == pytest.approx(5.0)
    assert sim.prim.kind == Primitive.IDLE


# ---------------------------------------------------------------------------- docking


def test_dock_only_within_reach() -> None:
    sim = Sim()
    sim.mussels[7] = MusselFix(P.dock_reach_m + 0.1, 0.0)
    sim.mussels[8] = MusselFix(0.0, P.dock_reach_m - 0.1)
    before = sim.prim
    assert sim.dock(1, 7) == Refusal.OUT_OF_REACH
    assert sim.prim is before
    assert sim.dock(1, 8) is None
    assert sim.prim.slot_state(1) == prim.SlotState(8, Latch.CLOSING, False, P.dock_time_s)


def test_dock_reach_is_a_run_time_parameter() -> None:
    sim = Sim(params=replace(P, dock_reach_m=5.0))
    sim.mussels[7] = MusselFix(4.0, 0.0)
    assert sim.dock(3, 7) is None


def test_dock_takes_dock_time_then_latches_and_charges() -> None:
    sim = Sim()
    sim.mussels[24] = MusselFix(1.0, 1.0)
    assert sim.dock(2, 24) is None
    p = sim.prim
    assert (p.kind, p.progress, p.slot, p.mussel_id) == (Primitive.DOCK, IN_PROGRESS, 2, 24)
    sim.run(P.dock_time_s - 0.5)
    assert sim.prim.slot_state(2).latch == Latch.CLOSING
    assert not sim.prim.slot_state(2).charging
    sim.run(0.6)
    assert sim.prim.slot_state(2) == prim.SlotState(24, Latch.LATCHED, True, 0.0)
    assert sim.prim.progress == Progress.DONE
    assert [s.latch for i, s in enumerate(sim.prim.slots) if i != 1] == [Latch.OPEN] * 3


def test_docking_holds_position_against_the_current() -> None:
    sim = Sim((0.2, 0.0))
    sim.mussels[5] = MusselFix(0.5, 0.0)
    assert sim.dock(1, 5) is None
    track = sim.run(P.dock_time_s + 1.0)
    assert max(dist(p, (0.0, 0.0)) for p in track) < 0.5
    assert sim.prim.slot_state(1).latch == Latch.LATCHED


def test_dock_fails_when_the_mussel_drifts_out_of_reach() -> None:
    sim = Sim()
    sim.mussels[9] = MusselFix(1.0, 0.0)
    assert sim.dock(4, 9) is None
    sim.run(3.0)
    sim.mussels[9] = MusselFix(3.0, 0.0)  # a new AMUSSEL_STATUS puts it beyond DOCK_REACH
    sim.tick()
    assert sim.prim.progress == Progress.FAILED
    assert sim.prim.slot_state(4) == prim.SlotState()


@pytest.mark.parametrize(
    ("slot", "mussel_id", "refusal"),
    [(0, 7, Refusal.BAD_SLOT), (5, 7, Refusal.BAD_SLOT), (1, 0, Refusal.BAD_MUSSEL_ID),
     (1, 99, Refusal.UNKNOWN_MUSSEL), (1, 11, Refusal.ALREADY_DOCKED)],
)
def test_dock_refusals(slot: int, mussel_id: int, refusal: Refusal) -> None:
    sim = Sim()
    sim.mussels[7] = MusselFix(0.0, 0.0)
    sim.mussels[11] = MusselFix(0.0, 0.0, docked=True)  # docked on another aPad
    assert sim.dock(slot, mussel_id) == refusal
    assert sim.prim == PrimitiveState()


def test_dock_refuses_an_occupied_slot_and_a_mussel_already_in_a_slot() -> None:
    sim = Sim()
    sim.mussels.update({1: MusselFix(0.5, 0.0), 2: MusselFix(-0.5, 0.0)})
    assert sim.dock(1, 1) is None
    assert sim.dock(1, 2) == Refusal.SLOT_OCCUPIED
    assert sim.dock(2, 1) == Refusal.ALREADY_DOCKED
    sim.run(P.dock_time_s + 0.2)
    assert sim.dock(1, 2) == Refusal.SLOT_OCCUPIED
    assert sim.dock(3, 1) == Refusal.ALREADY_DOCKED


def test_retried_dock_is_harmless() -> None:
    sim = Sim()
    sim.mussels[3] = MusselFix(1.0, 0.0)
    assert sim.dock(2, 3) is None
    sim.run(4.0)
    closing = sim.prim
    assert sim.dock(2, 3) is None  # the GCS retries: the latch is not restarted
    assert sim.prim is closing
    sim.run(P.dock_time_s - 4.0 + 0.2)
    assert sim.prim.slot_state(2).latch == Latch.LATCHED
    latched = sim.prim
    assert sim.dock(2, 3) is None
    assert sim.prim is latched


def test_undock_releases_for_undock_time_then_empties_the_slot() -> None:
    sim = Sim()
    sim.mussels[3] = MusselFix(1.0, 0.0)
    sim.dock(2, 3)
    sim.run(P.dock_time_s + 0.2)
    assert sim.undock(2, 3) is None
    p = sim.prim
    assert (p.kind, p.progress, p.slot, p.mussel_id) == (Primitive.UNDOCK, IN_PROGRESS, 2, 3)
    assert sim.prim.slot_state(2).latch == Latch.RELEASING
    assert not sim.prim.slot_state(2).charging
    sim.run(P.undock_time_s - 0.5)
    assert sim.prim.slot_state(2).latch == Latch.RELEASING
    sim.run(0.6)
    assert sim.prim.slot_state(2) == prim.SlotState()
    assert sim.prim.progress == Progress.DONE


def test_undock_refusals_and_retries_never_touch_another_slot() -> None:
    sim = Sim()
    sim.mussels.update({1: MusselFix(0.5, 0.0), 2: MusselFix(-0.5, 0.0)})
    sim.dock(1, 1)
    sim.dock(2, 2)
    sim.run(P.dock_time_s + 0.2)
    assert sim.undock(3) == Refusal.SLOT_EMPTY
    assert sim.undock(1, 2) == Refusal.WRONG_MUSSEL
    assert sim.undock(9) == Refusal.BAD_SLOT
    assert sim.undock(1, 1) is None
    sim.mussels[3] = MusselFix(0.0, 0.0)
    assert sim.dock(1, 3) == Refusal.SLOT_BUSY
    sim.run(2.0)
    releasing = sim.prim
    assert sim.undock(1, 1) is None  # retried while releasing: not restarted
    assert sim.prim is releasing
    sim.run(P.undock_time_s)
    assert sim.undock(1, 1) == Refusal.SLOT_EMPTY  # a late retry finds it empty and stops there
    assert sim.prim.slot_state(1) == prim.SlotState()
    assert sim.prim.slot_state(2) == prim.SlotState(2, Latch.LATCHED, True, 0.0)


def test_undock_aborts_a_dock_still_closing() -> None:
    sim = Sim()
    sim.mussels[4] = MusselFix(0.0, 0.0)
    sim.dock(1, 4)
    sim.run(2.0)
    assert sim.undock(1) is None
    sim.run(P.undock_time_s + 0.2)
    assert sim.prim.slot_state(1) == prim.SlotState()


def test_a_go_to_away_from_a_closing_dock_makes_it_fail() -> None:
    sim = Sim()
    sim.mussels[4] = MusselFix(0.0, 0.0)
    sim.dock(1, 4)
    sim.prim = prim.go_to(sim.prim, 20.0, 0.0)
    sim.run(P.dock_time_s)
    assert sim.prim.slot_state(1) == prim.SlotState()
    assert sim.prim.kind == Primitive.GOTO


def test_dock_and_undock_hold_the_point_a_finished_go_to_reached() -> None:
    sim = Sim((0.2, 0.0))
    sim.prim = prim.go_to(sim.prim, 10.0, 10.0)
    sim.run_until_done()
    sim.run(60.0)
    sim.mussels[6] = MusselFix(sim.vehicle.x_m, sim.vehicle.y_m)
    assert sim.dock(1, 6) is None
    assert (sim.prim.target_x_m, sim.prim.target_y_m) == (10.0, 10.0)
