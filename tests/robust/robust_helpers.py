"""A bare MAVLink GCS on the virtual clock, to poke the SITL aPad with chosen bytes."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from apad_sitl.endpoint import SitlVehicle
from apad_sitl.params import ApadParams
from mavlink_dialect import Codec, Transport, mavlink, memory_pair
from missiontime import VirtualClock
from mussel_sim.geo import LocalFrame
from mussel_sim.vocabulary import MusselState

HOME = (43.94, 15.44)
FRAME = LocalFrame(*HOME)
SYSID = 1
Msg = Any


def latlon_e7(x_m: float, y_m: float) -> tuple[int, int]:
    lat, lon = FRAME.to_geodetic(x_m, y_m)
    return round(float(lat) * 1e7), round(float(lon) * 1e7)


class BareGcs:
    """Its own Codec on one transport; decoded messages pile up in `inbox`."""

    def __init__(self, transport: Transport, clock: VirtualClock, codec: Codec | None = None) -> None:
        self.codec = codec or Codec(250, 190)
        self.transport, self.clock = transport, clock
        self.inbox: list[Msg] = []
        self.sent: list[bytes] = []

    def poll(self) -> bool:
        data = self.transport.receive()
        for chunk in data:
            self.inbox.extend(self.codec.decode(chunk))
        return bool(data)

    def fileno(self) -> int | None:
        return None

    def send(self, msg: Msg) -> bytes:
        frame = self.codec.encode(msg)
        self.send_raw(frame)
        return frame

    def send_raw(self, frame: bytes) -> None:
        self.sent.append(frame)
        self.transport.send(frame)
        self.clock.sleep(0.0)

    def acks(self, command: int) -> list[Msg]:
        return [m for m in self.inbox if m.get_type() == "COMMAND_ACK" and m.command == command]

    def heartbeat(self) -> None:
        self.send(mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3))

    def mussel(self, mussel_id: int, x_m: float, y_m: float, state: MusselState = MusselState.FLOATING) -> None:
        lat_e7, lon_e7 = latlon_e7(x_m, y_m)
        self.send(mavlink.MAVLink_amussel_status_message(
            self.clock.now_us, mussel_id, lat_e7, lon_e7, 0.0, 0.8, 4080, int(state), 1))

    def command_long(self, command: int, *params: float) -> bytes:
        p = [*params, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0][:7]
        return self.send(mavlink.MAVLink_command_long_message(SYSID, 1, command, 0, *p))

    def wait(self, done: Callable[[], bool], timeout_s: float) -> bool:
        deadline = self.clock.time() + timeout_s
        while not done():
            if self.clock.time() >= deadline:
                return False
            self.clock.sleep(0.1)
        return True


def sitl_pair(params: ApadParams | None = None, **vehicle_kw: Any) -> tuple[VirtualClock, SitlVehicle, BareGcs]:
    clock = VirtualClock()
    vehicle_end, gcs_end = memory_pair()
    vehicle = SitlVehicle(vehicle_end, params or ApadParams(), *HOME, system_id=SYSID, **vehicle_kw)
    vehicle.attach(clock.scheduler)
    gcs = BareGcs(gcs_end, clock)
    clock.scheduler.add_poller(gcs)
    clock.sleep(1.0)
    return clock, vehicle, gcs
