"""The GCS link and aPad API against the SITL aPad, over real MAVLink bytes.

Lockstep tests use the in-memory pair on a virtual clock; one test repeats the essentials over
real UDP sockets in real time. The aMussels are the real simulated fleet, publishing over MAVLink.
"""

from __future__ import annotations

import math
import socket

import numpy as np
import pytest

from apad_sitl.endpoint import SitlVehicle
from apad_sitl.params import ApadParams
from apad_sitl.vocabulary import Latch, Progress
from gcs.link.apad_api import ApadApi, Location
from gcs.link.command_protocol import BACKOFF
from gcs.link.router import CommandError, Link
from mavlink_dialect import Codec, mavlink, memory_pair, open_transport
from mavlink_dialect.transport import MemoryTransport, Transport
from missiontime import Clock, VirtualClock, WallClock
from mussel_sim.comms import FLEET_COMPONENT_ID, FLEET_SYSTEM_ID, FleetRunner
from mussel_sim.fleet_state import FleetParams, state_from_arrays
from mussel_sim.geo import LocalFrame, distance_m
from mussel_sim.vocabulary import MusselState

pytestmark = pytest.mark.sitl

HOME = (43.9400, 15.4400)
FRAME = LocalFrame(*HOME)
# aMussels resting on the seabed at these east/north offsets from the aPad's home [m].
MUSSELS = {11: (1.0, 0.5), 12: (30.0, 0.0), 13: (0.0, -25.0)}


class World:
    def __init__(self, clock: Clock, gcs_end: Transport, apad_end: Transport, current: tuple[float, float] = (0, 0),
                 params: ApadParams | None = None, apad_ids: tuple[int, ...] = (1,)) -> None:
        self.clock = clock
        self.link = Link(clock)
        self.link.add_transport(gcs_end)
        self.vehicle = SitlVehicle(apad_end, params or ApadParams(), *HOME, system_id=apad_ids[0], current_mps=current)
        self.vehicle.attach(clock.scheduler, clock.now_us)
        fleet_params = FleetParams(drift_half_width_m=0.0)
        ids = list(MUSSELS)
        state = state_from_arrays(ids, [MUSSELS[i][0] for i in ids], [MUSSELS[i][1] for i in ids],
                                  [0.5] * len(ids), fleet_params, clock.now_us)
        port = self.link.attach(None)
        self.fleet = FleetRunner(state, fleet_params, np.random.default_rng(0), FRAME,
                                 Codec(FLEET_SYSTEM_ID, FLEET_COMPONENT_ID), port.send_bytes, local=port.send_local,
                                 local_batch=port.send_batch)
        port.handler = self.fleet.handle
        self.fleet.register(clock.scheduler, clock.now_us)
        self.api = ApadApi(self.link, clock)
        self.apad_id = self.api.wait_apad(timeout_s=5.0)
        clock.sleep(1.5)  # first aMussel statuses reach both ends

    def apad_distance_to(self, target: Location) -> float:
        here = self.api.position(self.apad_id)
        return float(distance_m(here.lat, here.lon, target.lat, target.lon))

    def wait_primitive(self, timeout_s: float = 300.0, period_s: float = 0.5) -> Progress:
        deadline = self.clock.time() + timeout_s
        while self.api.primitive_status(self.apad_id) == Progress.IN_PROGRESS:
            assert self.clock.time() < deadline, "primitive never finished"
            self.clock.sleep(period_s)
        return self.api.primitive_status(self.apad_id)


def lockstep(**kwargs: object) -> World:
    gcs_end, apad_end = memory_pair()
    return World(VirtualClock(), gcs_end, apad_end, **kwargs)  # type: ignore[arg-type]


def offset(east_m: float, north_m: float) -> Location:
    lat, lon = FRAME.to_geodetic(east_m, north_m)
    return Location(float(lat), float(lon))


def test_go_to_arrives_within_the_victory_radius_listing1_style() -> None:
    w = lockstep()
    target = w.api.get_location(12)
    w.api.go_to([target.lat, target.lon], speed=0.5, radius=1.5)
    steps = 0
    while w.api.goto_status(w.apad_id) == 1:  # the paper's Listing 1 loop, verbatim in spirit
        w.clock.sleep(1)
        steps += 1
    assert w.api.goto_status(w.apad_id) == Progress.DONE
    assert w.apad_distance_to(target) <= 1.5
    assert 55 <= steps <= 120  # 30 m at 0.5 m/s, with acceleration and braking
    # The GCS's view of the primitive agrees with the vehicle's odometer.
    assert w.api.apad(w.apad_id).primitive.distance_travelled_m == pytest.approx(29.0, abs=1.5)


def test_hold_keeps_position_under_current() -> None:
    w = lockstep(current=(0.2, -0.1))
    start = w.api.position(w.apad_id)
    w.api.hold()
    worst = 0.0
    for _ in range(240):
        w.clock.sleep(0.5)
        worst = max(worst, w.apad_distance_to(start))
    assert worst < 1.0, f"drifted {worst:.2f} m under a 0.22 m/s current"


def test_without_hold_the_current_carries_the_apad_away() -> None:
    # The same current with the thrusters idle (disarmed): proves the hold test measures control.
    w = lockstep(current=(0.2, 0.0))
    start = w.api.position(w.apad_id)
    w.link.commands.send_long(w.apad_id, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, (0,))
    w.clock.sleep(30)
    assert w.apad_distance_to(start) > 4.0


def test_dock_succeeds_within_reach_and_fills_the_slot() -> None:
    w = lockstep()
    w.api.docking(True, 3, 11)  # aMussel 11 rests 1.1 m away
    assert w.wait_primitive() == Progress.DONE
    w.clock.sleep(1.5)  # slot status and the fleet's next step
    slot = w.api.slots(w.apad_id)[2]
    assert (slot.mussel_id, slot.latch, slot.charging) == (11, Latch.LATCHED, True)
    assert w.api.mussels[11].state == MusselState.DOCKED
    assert w.api.mussels[11].location == pytest.approx(w.api.position(w.apad_id), abs=1e-6)


def test_dock_out_of_reach_is_refused_and_the_slot_stays_empty() -> None:
    w = lockstep()
    with pytest.raises(CommandError, match="MAV_RESULT_DENIED") as err:
        w.api.docking(True, 1, 12)  # 30 m away
    assert err.value.result == mavlink.MAV_RESULT_DENIED
    w.clock.sleep(1.5)
    assert all(s.latch == Latch.OPEN and s.mussel_id == 0 for s in w.api.slots(w.apad_id))
    assert w.api.mussels[12].state == MusselState.ACTIVE


def test_undock_empties_the_slot_and_the_amussel_sinks_back_to_work() -> None:
    w = lockstep()
    w.api.docking(True, 2, 11)
    assert w.wait_primitive() == Progress.DONE
    w.api.docking(False, 2, 11)
    assert w.wait_primitive() == Progress.DONE
    w.clock.sleep(1.5)
    slot = w.api.slots(w.apad_id)[1]
    assert (slot.mussel_id, slot.latch, slot.charging) == (0, Latch.OPEN, False)
    assert w.api.mussels[11].state == MusselState.SINKING
    w.clock.sleep(25)
    assert w.api.mussels[11].state == MusselState.ACTIVE


def test_a_parameter_set_changes_behaviour() -> None:
    def go_to_time(speed_max: float | None) -> float:
        w = lockstep()
        if speed_max is not None:
            assert w.link.params.set(w.apad_id, "SPEED_MAX", speed_max) == pytest.approx(speed_max)
        start = w.clock.time()
        w.api.go_to(w.api.get_location(13))  # speed <= 0: the aPad's own SPEED_MAX
        assert w.wait_primitive() == Progress.DONE
        return w.clock.time() - start

    default, slow = go_to_time(None), go_to_time(0.25)
    assert slow == pytest.approx(2 * default, rel=0.15)


def test_an_out_of_range_parameter_is_refused() -> None:
    w = lockstep()
    with pytest.raises(ValueError, match="refused SPEED_MAX"):
        w.link.params.set(w.apad_id, "SPEED_MAX", 99.0)


def test_an_unknown_command_is_nacked_never_silent() -> None:
    w = lockstep()
    with pytest.raises(CommandError) as err:
        w.link.commands.send_long(w.apad_id, mavlink.MAV_CMD_USER_1, (1, 2, 3))
    assert err.value.result == mavlink.MAV_RESULT_UNSUPPORTED


class DropFirst(MemoryTransport):
    """An in-memory end that loses its first `n` outgoing datagrams, like a radio fade."""

    def __init__(self, label: str, n: int) -> None:
        super().__init__(label)
        self.to_drop = n

    def send(self, data: bytes) -> None:
        if self.to_drop > 0:
            self.to_drop -= 1
            return
        super().send(data)


def lossy_pair(n: int) -> tuple[MemoryTransport, MemoryTransport]:
    a, b = DropFirst("gcs", n), MemoryTransport("apad")
    a.peer, b.peer = b, a
    return a, b


def test_a_lost_command_is_retried_until_acked() -> None:
    gcs_end, apad_end = lossy_pair(0)
    w = World(VirtualClock(), gcs_end, apad_end)
    gcs_end.to_drop = 2  # the command and its first retry vanish
    w.api.docking(True, 1, 11)
    assert gcs_end.to_drop == 0
    assert w.wait_primitive() == Progress.DONE
    assert w.api.slots(w.apad_id)[0].mussel_id == 11


def test_no_ack_at_all_surfaces_as_a_command_error() -> None:
    gcs_end, apad_end = lossy_pair(0)
    w = World(VirtualClock(), gcs_end, apad_end)
    gcs_end.to_drop = 10**6  # the uplink is gone
    start = w.clock.time()
    with pytest.raises(CommandError, match="no COMMAND_ACK"):
        w.api.hold()
    # 4 attempts, each waiting BACKOFF times longer than the one before: 1 + 1.5 + 2.25 + 3.375 s.
    assert w.clock.time() - start == pytest.approx(sum(BACKOFF**k for k in range(4)), abs=0.1)


def test_several_apads_are_kept_apart_by_system_id() -> None:
    clock = VirtualClock()
    gcs1, apad1 = memory_pair("one")
    w = World(clock, gcs1, apad1)
    gcs2, apad2 = memory_pair("two")
    second = SitlVehicle(apad2, ApadParams(), *HOME, system_id=2)
    second.attach(clock.scheduler, clock.now_us)
    w.link.add_transport(gcs2)
    w.link.wait_vehicle(system_id=2)
    clock.sleep(1.5)
    assert set(w.link.vehicles) == {1, 2}
    w.api.go_to(w.api.get_location(13), apad_id=2)
    clock.sleep(20)
    assert second.state.distance_travelled_m > 5.0
    assert w.vehicle.state.distance_travelled_m == pytest.approx(0.0, abs=0.01)
    with pytest.raises(LookupError, match="2 aPads known"):
        w.api.hold()  # with two aPads the id is required


def test_over_real_udp_in_real_time() -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    apad_end = open_transport(f"udp:127.0.0.1:{port}", listen=True)
    gcs_end = open_transport(f"udp:127.0.0.1:{port}")
    params = ApadParams(speed_max_mps=1.0, accel_max_mps2=1.0, dock_time_s=1.0)
    w = World(WallClock(), gcs_end, apad_end, params=params)
    try:
        target = offset(0.0, 0.9)  # aMussel 11 is within reach from here
        w.api.go_to(target, radius=0.5)
        assert w.wait_primitive(timeout_s=10) == Progress.DONE  # (the position heard lags the status a little)
        assert w.apad_distance_to(target) <= 0.5
        w.api.docking(True, 4, 11)
        assert w.wait_primitive(timeout_s=10, period_s=0.05) == Progress.DONE  # looked at every 50 ms, not 0.5 s
        deadline = w.clock.time() + 5.0  # the slot's next DOCK_SLOT_STATUS (1 Hz) names aMussel 11
        while w.api.slots(w.apad_id)[3].mussel_id != 11 and w.clock.time() < deadline:
            w.clock.sleep(0.05)
        assert w.api.slots(w.apad_id)[3].mussel_id == 11
        assert w.link.codec.stats.sent > 0 and w.vehicle.codec.stats.bad_data == 0
    finally:
        w.vehicle.close()
        w.link.close()


def test_goto_status_waits_for_the_new_primitive_not_a_stale_report() -> None:
    # Right after the ACK the last report may still be about the previous, finished Go To.
    w = lockstep()
    w.api.go_to(offset(0.0, 2.0))
    assert w.wait_primitive() == Progress.DONE
    w.api.go_to(offset(0.0, 12.0))
    assert w.api.goto_status(w.apad_id) == Progress.IN_PROGRESS
    assert w.wait_primitive() == Progress.DONE
    assert w.apad_distance_to(offset(0.0, 12.0)) <= 1.0
    assert math.isfinite(w.api.apad(w.apad_id).primitive.distance_to_go_m)
