"""MAVSDK-Python 4.1 (the C++ MAVSDK in-process through ctypes) against a `vil sitl` subprocess.

Most third-party MAVLink apps are built on MAVSDK: if its stock Action, Telemetry, Param and
MavlinkDirect plugins work the aPad, so do they. Each test runs one `asyncio.run` under a
deadline; the SITL is a real process on a free UDP port.

Connection strings that work (MAVSDK 2+ syntax):
    vil sitl --listen udp:127.0.0.1:P    +  add_any_connection("udpout://127.0.0.1:P")
    vil sitl --connect udp:127.0.0.1:P   +  add_any_connection("udpin://127.0.0.1:P")
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import math
import socket
from collections.abc import AsyncGenerator, Callable
from pathlib import Path
from typing import Any, TypeVar

import pytest
from interop_procs import HOME, Procs, read_events
from testkit import free_udp_port

pytest.importorskip("mavsdk", reason="MAVSDK is in the interop extra: pip install -e '.[interop]'")

from mavsdk.asyncio import Autopilot, ComponentType, Configuration, Mavsdk, System
from mavsdk.asyncio.plugins.action import ActionAsync
from mavsdk.asyncio.plugins.mavlink_direct import MavlinkDirectAsync, MavlinkDirectError
from mavsdk.asyncio.plugins.param import ParamAsync
from mavsdk.asyncio.plugins.telemetry import FlightMode, Position, TelemetryAsync

import mavlink_dialect
from mavlink_dialect import Codec, mavlink
from mussel_sim.comms import FLEET_COMPONENT_ID, FLEET_SYSTEM_ID
from mussel_sim.geo import LocalFrame
from mussel_sim.vocabulary import MusselState

pytestmark = [pytest.mark.interop, pytest.mark.slow]

T = TypeVar("T")
FRAME = LocalFrame(*HOME)
DIALECT_XML = Path(mavlink_dialect.__file__).with_name("subcultron.xml")
# MAVSDK names ArduRover's custom modes after PX4's: HOLD (4) is HOLD, GUIDED (15) is OFFBOARD.
MAVSDK_GUIDED = FlightMode.OFFBOARD


def metres_between(lat_a: float, lon_a: float, lat_b: float, lon_b: float) -> float:
    xa, ya = FRAME.to_local(lat_a, lon_a)
    xb, yb = FRAME.to_local(lat_b, lon_b)
    return math.hypot(float(xa) - float(xb), float(ya) - float(yb))


async def first(stream: AsyncGenerator[T, None], what: str, timeout_s: float, match: Callable[[T], bool] = bool) -> T:
    """The first item of a MAVSDK subscription that `match`es; closes the subscription either way."""
    async with contextlib.aclosing(stream) as items:
        try:
            async with asyncio.timeout(timeout_s):
                async for item in items:
                    if match(item):
                        return item
        except TimeoutError:
            pass
    pytest.fail(f"MAVSDK: no {what} within {timeout_s:g} s")


async def collect(stream: AsyncGenerator[T, None], duration_s: float) -> list[T]:
    """Everything a subscription yields during `duration_s`."""
    out: list[T] = []
    async with contextlib.aclosing(stream) as items:
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(duration_s):
                async for item in items:
                    out.append(item)
    return out


def ground_station() -> Mavsdk:
    return Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))


async def connect(sdk: Mavsdk, url: str) -> System:
    await sdk.add_any_connection(url)
    system = await sdk.first_autopilot(timeout_s=10.0)
    assert system is not None, f"MAVSDK found no autopilot on {url} within 10 s"
    return system


# ---------------------------------------------------------------------------------- Go To and Hold


async def _goto_then_hold(url: str, target: tuple[float, float]) -> dict[str, Any]:
    async with ground_station() as sdk:
        system = await connect(sdk, url)
        assert await system.autopilot_type() == Autopilot.ARDUPILOT  # we look like ArduRover
        telemetry, action, param = TelemetryAsync(system), ActionAsync(system), ParamAsync(system)
        try:
            start = await first(telemetry.subscribe_position(), "position", 5.0)
            assert metres_between(start.latitude_deg, start.longitude_deg, *HOME) < 0.5
            await first(telemetry.subscribe_flight_mode(), "HOLD at boot", 3.0, lambda m: m == FlightMode.HOLD)

            # The Param plugin: a quick boat for a quick test, read back through MAVSDK.
            await param.set_param_float("SPEED_MAX", 3.0)
            assert await param.get_param_float("SPEED_MAX") == pytest.approx(3.0)

            await action.goto_location(target[0], target[1], 0.0, math.nan)
            await first(telemetry.subscribe_flight_mode(), "GUIDED after goto_location", 3.0,
                        lambda m: m == MAVSDK_GUIDED)
            arrived = await first(
                telemetry.subscribe_position(), "arrival within 0.3 m of the target", 20.0,
                lambda p: metres_between(p.latitude_deg, p.longitude_deg, *target) <= 0.3,
            )

            await action.hold()
            await first(telemetry.subscribe_flight_mode(), "HOLD after hold()", 3.0, lambda m: m == FlightMode.HOLD)
            held: list[Position] = await collect(telemetry.subscribe_position(), 2.5)
            mode_after = await first(telemetry.subscribe_flight_mode(), "flight mode", 3.0, lambda m: True)
            return {"start": start, "arrived": arrived, "held": held, "mode_after": mode_after}
        finally:
            for plugin in (telemetry, action, param):
                plugin.destroy()


def test_mavsdk_goto_location_moves_the_apad_and_hold_keeps_it_there(procs: Procs, tmp_path: Path) -> None:
    port = free_udp_port()
    logs = tmp_path / "sitl"
    sitl = procs.sitl("--listen", f"udp:127.0.0.1:{port}", "--param", "ACCEL_MAX=2.0", "--param", "HOLD_KP=1.5",
                      log_dir=logs)
    lat, lon = FRAME.to_geodetic(6.0, 8.0)  # 10 m north-north-east of home
    target = (float(lat), float(lon))

    r = asyncio.run(asyncio.wait_for(_goto_then_hold(f"udpout://127.0.0.1:{port}", target), timeout=40.0))

    arrived: Position = r["arrived"]
    held: list[Position] = r["held"]
    assert len(held) >= 5, "the SITL sends GLOBAL_POSITION_INT at 4 Hz"
    drift = max(metres_between(p.latitude_deg, p.longitude_deg, arrived.latitude_deg, arrived.longitude_deg)
                for p in held)
    assert drift <= 1.0, f"HOLD let the aPad wander {drift:.2f} m"
    end = held[-1]
    assert metres_between(end.latitude_deg, end.longitude_deg, *target) <= 1.0
    assert r["mode_after"] == FlightMode.HOLD

    # The aPad's own record of what MAVSDK put on the wire.
    assert sitl.stop() == 0
    events = read_events(logs)
    commands = [e for e in events if e["event"] == "command" and e["name"] != "MAV_CMD_REQUEST_MESSAGE"]
    assert all(c["result"] == "ACCEPTED" for c in commands), commands
    (source,) = {tuple(c["source"]) for c in commands}  # one MAVSDK, one (system, component)
    assert source[0] != 1
    (goto,) = [c for c in commands if c["name"] == "MAV_CMD_DO_REPOSITION"]
    if goto["frame"] is None:  # COMMAND_LONG: degrees
        assert goto["params"][4:6] == pytest.approx(list(target), abs=1e-7)
    else:  # COMMAND_INT: degE7
        assert goto["params"][4:6] == [round(target[0] * 1e7), round(target[1] * 1e7)]
    modes = [int(c["params"][1]) for c in commands if c["name"] == "MAV_CMD_DO_SET_MODE"]
    assert modes[-1] == 4 and 15 in modes, modes  # GUIDED for the Go To, HOLD last
    assert [(e["name"], e["new"]) for e in events if e["event"] == "param"] == [("SPEED_MAX", pytest.approx(3.0))]


# ---------------------------------------------------------------------------------- MavlinkDirect

STATUS = {  # one AMUSSEL_STATUS as the shore station's simulated fleet would publish it
    "time_us": 123_456_789,
    "mussel_id": 24,
    "lat": round((HOME[0] + 0.0001) * 1e7),
    "lon": round((HOME[1] - 0.0002) * 1e7),
    "depth": 3.25,  # exact in float32, so the decoded JSON must equal it
    "battery": 0.75,
    "battery_voltage": 4050,
    "state": int(MusselState.FLOATING),
    "simulated": 1,
}


async def _publish_fleet(port: int, stop: asyncio.Event) -> None:
    """The aMussel fleet's party: a HEARTBEAT (MAVSDK only knows systems it has heard one from)
    and AMUSSEL_STATUS at 10 Hz, straight to the port MAVSDK listens on."""
    codec = Codec(FLEET_SYSTEM_ID, FLEET_COMPONENT_ID)
    heartbeat = mavlink.MAVLink_heartbeat_message(
        mavlink.MAV_TYPE_ONBOARD_CONTROLLER, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, mavlink.MAV_STATE_ACTIVE, 3
    )
    status = mavlink.MAVLink_amussel_status_message(**STATUS)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        while not stop.is_set():
            for msg in (heartbeat, status):
                sock.sendto(codec.encode(msg), ("127.0.0.1", port))
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(0.1):
                    await stop.wait()


async def _system(sdk: Mavsdk, system_id: int, timeout_s: float) -> System:
    async with asyncio.timeout(timeout_s):
        while True:
            for system in await sdk.get_systems():
                if await system.get_system_id() == system_id:
                    return system
            await asyncio.sleep(0.05)


async def _mavlink_direct(port: int) -> dict[str, Any]:
    stop = asyncio.Event()
    async with ground_station() as sdk:
        apad = await connect(sdk, f"udpin://127.0.0.1:{port}")
        publisher = asyncio.create_task(_publish_fleet(port, stop))
        plugins: list[MavlinkDirectAsync] = []
        try:
            fleet = await _system(sdk, FLEET_SYSTEM_ID, 5.0)
            fleet_direct, apad_direct = MavlinkDirectAsync(fleet), MavlinkDirectAsync(apad)
            plugins += [fleet_direct, apad_direct]

            # Without our XML, MAVSDK drops the dialect's frames: it delivers the fleet's heartbeats only.
            before = {m.message_name for m in await collect(fleet_direct.subscribe_message(""), 0.6)}

            # A broken definition is refused, so a successful load below means MAVSDK parsed ours.
            with pytest.raises(MavlinkDirectError):
                await fleet_direct.load_custom_xml(DIALECT_XML.read_text(encoding="utf-8")[:400])
            # Shipped as it is, <include>common.xml</include> and all: MAVSDK 4.1 does not resolve
            # includes of an XML given as a string (a missing include loads too) and adds our
            # messages to its built-in set (common + ardupilotmega), which our 54000 block clashes with not.
            await fleet_direct.load_custom_xml(DIALECT_XML.read_text(encoding="utf-8"))

            mussel = await first(fleet_direct.subscribe_message("AMUSSEL_STATUS"), "AMUSSEL_STATUS", 5.0)
            primitive = await first(apad_direct.subscribe_message("PRIMITIVE_STATUS"), "PRIMITIVE_STATUS", 3.0)
            slot = await first(apad_direct.subscribe_message("DOCK_SLOT_STATUS"), "DOCK_SLOT_STATUS", 3.0)
            return {"before": before, "mussel": mussel, "primitive": primitive, "slot": slot}
        finally:
            stop.set()
            await publisher
            for plugin in plugins:
                plugin.destroy()


def test_mavsdk_mavlink_direct_decodes_our_dialect_from_subcultron_xml(procs: Procs) -> None:
    port = free_udp_port()
    procs.sitl("--connect", f"udp:127.0.0.1:{port}")

    r = asyncio.run(asyncio.wait_for(_mavlink_direct(port), timeout=30.0))

    assert "HEARTBEAT" in r["before"] and "AMUSSEL_STATUS" not in r["before"], r["before"]
    mussel = r["mussel"]
    assert (mussel.system_id, mussel.component_id) == (FLEET_SYSTEM_ID, FLEET_COMPONENT_ID)
    fields = json.loads(mussel.fields_json)
    assert fields["message_id"] == mavlink.MAVLINK_MSG_ID_AMUSSEL_STATUS == 54000
    assert {k: fields[k] for k in STATUS} == STATUS

    primitive = json.loads(r["primitive"].fields_json)  # the SITL's own dialect telemetry
    assert r["primitive"].system_id == 1
    assert primitive["primitive"] == mavlink.APAD_PRIMITIVE_IDLE and primitive["progress"] == 0
    slot = json.loads(r["slot"].fields_json)
    assert 1 <= slot["slot"] <= 4 and slot["mussel_id"] == 0 and slot["latch"] == mavlink.DOCK_LATCH_STATE_OPEN
