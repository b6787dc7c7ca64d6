"""A resting aPad's physics task parked off the scheduler (apad_sitl.parking) against ticking it.

Two SITL aPads run the same script over real MAVLink bytes, one parking its physics at rest and one
ticking at 10 Hz throughout: a GCS heartbeat that stops and comes back, Go Tos, a parameter set, a
failsafe taken on a Go To sent while the link is lost, charging at the home charger and held full
there for an hour, and a part that sends from a poller of its own while the hull rests (as the
aPad's modem answers its serial port). Every byte each sends, its .tlog and event log to the byte (each record's stamp),
every read of its hull by tasks before and after it in an instant's order, its final state and
energy counters are the same; the parked one ran a small part of the ticks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from testkit import go_to_bytes

from apad_sitl.endpoint import SitlVehicle
from apad_sitl.params import ApadParams
from apad_sitl.vehicle import BATTERY_FULL_V, VehicleState
from mavlink_dialect import Codec, mavlink, memory_pair
from missiontime import US_PER_S, Scheduler, VirtualClock
from mussel_sim.geo import LocalFrame

HOME = (43.94, 15.44)
FRAME = LocalFrame(*HOME)
END_S = 4_000.0




@dataclass
class Run:
    """What one aPad did: the bytes it sent, the hull as tasks read it, and how it ended."""

    sent: list[bytes] = field(default_factory=list)
    reads: list[tuple[str, int, bool, bool, float, float, float]] = field(default_factory=list)
    end: tuple[object, ...] = ()
    logs: dict[str, bytes] = field(default_factory=dict)
    ticks: int = 0
    parks: int = 0


class _SaysWhenAsked:
    """A poller of its own on the scheduler that sends through the vehicle when asked (as its modem
    answers what its serial port brought): its STATUSTEXT is stamped in the .tlog at the vehicle's time."""

    def __init__(self, vehicle: SitlVehicle) -> None:
        self.vehicle = vehicle
        self.asked = 0

    def poll(self) -> bool:
        if not self.asked:
            return False
        self.asked -= 1
        self.vehicle.statustext(mavlink.MAV_SEVERITY_INFO, "asked")
        return True

    def fileno(self) -> int | None:
        return None


def _run(park: bool, log_dir: Path) -> Run:
    apad_end, gcs_end = memory_pair()
    clock = VirtualClock(Scheduler())
    vehicle = SitlVehicle(apad_end, ApadParams(fs_gcs_enable=1, fs_gcs_timeout_s=5.0), *HOME, park_at_rest=park,
                          log_dir=log_dir)
    asker = _SaysWhenAsked(vehicle)
    vehicle.state = VehicleState(x_m=10.0, y_m=10.0, battery_v=14.5)  # charged at home, then held full there
    gcs = Codec(250, 190)
    run = Run()

    def script(now_us: int) -> None:  # the GCS, before the aPad in each instant's order
        t = now_us / US_PER_S
        if (t < 120 or t >= 200) and t == int(t):
            gcs_end.send(gcs.encode(mavlink.MAVLink_heartbeat_message(
                mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3)))
        if t == 60:
            gcs_end.send(go_to_bytes(gcs, FRAME, 10.0, 30.0))
        if t == 90:
            gcs_end.send(gcs.encode(mavlink.MAVLink_param_set_message(
                1, 1, b"FS_GCS_TIMEOUT", 4.0, mavlink.MAV_PARAM_TYPE_REAL32)))
        if t == 130:  # the link is lost: the aPad sets off, and the failsafe holds it
            gcs_end.send(go_to_bytes(gcs, FRAME, 10.0, 10.0))
        if t == 250:
            gcs_end.send(go_to_bytes(gcs, FRAME, 0.0, 0.0))  # to the home charger, to be held full there for hours
        if t in (30.2, 45.7, 3_000.3):  # resting, between its streams: away from home, then held full at home
            asker.asked += 1
        run.sent.extend(gcs_end.receive())

    def reader(name: str) -> object:
        def read(now_us: int) -> None:
            failsafe, lost, s = vehicle.failsafe_active, vehicle.gcs_link_lost(), vehicle.state
            run.reads.append((name, now_us, failsafe, lost, s.x_m, s.y_m, s.battery_v))
        return read

    clock.scheduler.every(0.1, script, "gcs")
    clock.scheduler.every(0.7, reader("before"), "reader-before")
    vehicle.attach(clock.scheduler)
    clock.scheduler.add_poller(asker)
    clock.scheduler.every(0.3, reader("after"), "reader-after")
    clock.sleep(END_S)
    vehicle.close()
    run.sent.extend(gcs_end.receive())
    assert vehicle.physics is not None
    run.ticks, run.parks = vehicle.physics.ticks, vehicle.physics.parks
    run.logs = {p.name: p.read_bytes() for p in sorted(log_dir.iterdir())}
    run.end = (vehicle.state, vehicle.energy_counters, vehicle.now_us, vehicle.modes.failsafe_holds,
               vehicle.failsafe_active, vehicle.params, dict(vehicle.dropped))
    return run


def test_a_parked_physics_task_gives_what_ticking_gives_to_the_byte(tmp_path: Path) -> None:
    ticking, parked = _run(False, tmp_path / "ticking"), _run(True, tmp_path / "parked")
    assert ticking.parks == 0 and ticking.ticks == round(END_S * 10) + 1
    assert len(ticking.sent) > 10_000 and len(ticking.reads) > 15_000
    assert parked.sent == ticking.sent  # heartbeats, telemetry, acks, the failsafe's STATUSTEXT, every stamp
    assert parked.reads == ticking.reads
    assert parked.end == ticking.end
    assert set(parked.logs) == {"apad1.tlog", "apad1.events.jsonl"} and parked.logs == ticking.logs
    assert ticking.logs["apad1.events.jsonl"].count(b'"failsafe"') == 1
    assert sum(1 for m in parked.sent if b"asked" in m) == 3
    state, energy, _, failsafe_holds, _, params, _ = parked.end
    assert failsafe_holds == 1 and params.fs_gcs_timeout_s == 4.0  # the script did what it says
    assert energy.home_wh > 50.0 and math.hypot(state.x_m, state.y_m) < 2.0  # charged at home, then held full
    assert state.battery_v == BATTERY_FULL_V and energy.home_charges == 1
    assert parked.parks >= 3 and parked.ticks < ticking.ticks / 5  # parked at rest: most ticks never ran
