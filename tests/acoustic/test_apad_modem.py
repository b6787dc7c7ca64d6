"""An aPad's own nanomodem reached over MAVLink: the GCS's driver through `ApadModemPort`, the
aPad's `ModemSerial` on its SITL, real MAVLink bytes between them (an in-memory pair on one virtual
clock), the emulator's water beyond."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from acoustic.nanomodem.driver import ModemDriver, Outcome
from acoustic.nanomodem.emulator import FrameKind, ModemEmulator, RemoteUnit
from acoustic.nanomodem.lockstep import attach
from acoustic.nanomodem.ports import pipe
from acoustic.nanomodem.replies import Range, Status
from acoustic.params import AcousticParams
from apad_sitl.endpoint import SitlVehicle
from apad_sitl.modem_serial import MAX_HOLD_MS
from apad_sitl.params import ApadParams
from gcs.acoustic.apad_modem_port import HOLD_MS, ApadModemPort
from gcs.link.router import Link
from mavlink_dialect import mavlink, memory_pair
from missiontime import VirtualClock

HOME = (43.9400, 15.4400)
MUSSEL = RemoteUnit(7, (30.0, 0.0, 3.0))
UNIT = 255


class Rig:
    def __init__(self) -> None:
        self.clock = clock = VirtualClock()
        self.link = Link(clock)
        gcs_end, apad_end = memory_pair("apad1")
        self.link.add_transport(gcs_end)
        _, gcs_modem = pipe()
        modem_port, water_end = pipe()
        self.core = ModemEmulator(AcousticParams(), (MUSSEL,), np.random.default_rng(1),
                                  hosted=(RemoteUnit(UNIT, (0.0, 0.0, 0.5)),))
        attach(self.core, gcs_modem, clock, hosted=(water_end,))
        self.placed = 0
        self.vehicle = SitlVehicle(apad_end, ApadParams(), *HOME, system_id=1, modem=(modem_port, self._place))
        self.vehicle.attach(clock.scheduler, clock.now_us)
        self.port = ApadModemPort(self.link, 1, clock)
        self.driver = ModemDriver(self.port, clock)
        self.link.wait_vehicle(5.0, 1)

    def _place(self) -> None:
        self.placed += 1
        self.core.move_remotes([UNIT], np.array([[0.0, 0.0, 0.5]]))

    def send(self, **fields: Any) -> None:
        f = {"target_system": 1, "target_component": 0, "flags": mavlink.SERIAL_CONTROL_FLAG_RESPOND,
             "timeout": 0, "count": 0, "data": bytes(64), **fields}
        self.link.send(mavlink.MAVLink_apad_modem_serial_message(**f))
        self.clock.sleep(0.1)


def test_the_gcs_driver_pings_and_calls_up_through_the_apads_modem() -> None:
    rig = Rig()
    status = rig.driver.status()
    assert isinstance(status.reply, Status) and status.reply.address == UNIT
    ping = rig.driver.ping(7)
    assert isinstance(ping.reply, Range) and abs(ping.reply.range_m(1500.0) - float(np.hypot(30.0, 2.5))) < 0.1
    assert rig.driver.unicast_ack(7, b"up").ok
    assert [(a, f.kind, f.source) for _, a, f in rig.core.heard.entries] == [
        (7, FrameKind.PING, UNIT), (7, FrameKind.UNICAST_ACK, UNIT)]
    assert rig.placed == 3  # the unit put where the aPad is before each command went to it
    assert rig.driver.dropped == {} and rig.port.dropped == {} and not rig.vehicle.dropped


def test_a_held_request_is_answered_at_its_timeout_and_a_quiet_modem_costs_one_message_a_hold() -> None:
    rig = Rig()
    before = rig.port.requests
    t0 = rig.clock.time()
    assert rig.port.read() == b""  # asks; the aPad holds the request
    while rig.clock.time() - t0 < 10 * HOLD_MS / 1000:
        assert rig.port.read() == b""
        rig.clock.sleep(0.005)  # the driver's pace
    assert 9 <= rig.port.requests - before <= 11  # about one request per hold, not one per look
    assert rig.port.dropped == {}


def test_what_the_apad_refuses_is_counted_and_a_lost_request_is_asked_again() -> None:
    rig = Rig()
    rig.send(count=65)
    rig.send(flags=mavlink.SERIAL_CONTROL_FLAG_REPLY, count=1, data=b"$".ljust(64, b"\0"))
    assert rig.vehicle.dropped == {"invalid:APAD_MODEM_SERIAL:count": 1, "invalid:APAD_MODEM_SERIAL:flags": 1}
    rig.send(target_system=2, count=2, data=b"$?".ljust(64, b"\0"))  # another aPad's: not written
    assert rig.core.counts.get("command", 0) == 0
    # A request the link lost: no answer comes, and past its hold the port asks again.
    rig.link.send = lambda msg: None  # type: ignore[method-assign]  # everything lost from here
    rig.port.read()
    rig.clock.sleep(HOLD_MS / 1000 + 0.5)
    rig.port.read()
    assert rig.port.dropped == {}  # within its hold and the margin: still waited for
    rig.clock.sleep(1.0)
    rig.port.read()
    assert rig.port.dropped == {"request_unanswered": 1}


def test_a_modem_that_has_gone_is_an_event_and_the_driver_waits_to_its_bound() -> None:
    rig = Rig()
    assert rig.vehicle.modem is not None
    rig.vehicle.modem.port.close()  # the modem's cable pulled
    assert rig.driver.status().outcome is Outcome.NO_REPLY
    assert rig.vehicle.modem.gone is not None
    assert rig.vehicle.dropped == {"unsupported:APAD_MODEM_SERIAL:modem_gone": 1}  # its `$?`, written nowhere
    assert rig.driver.status().outcome is Outcome.NO_REPLY
    assert rig.vehicle.dropped == {"unsupported:APAD_MODEM_SERIAL:modem_gone": 2}
    assert rig.core.counts["host_gone"] == 1  # the water's side of it, too; the water goes on
    assert [a for _, a, _ in rig.core.heard.entries] == []


def test_the_hold_is_bounded() -> None:
    rig = Rig()
    rig.send(timeout=65535)
    t0 = rig.clock.time()
    got: list[Any] = []
    rig.link.attach(lambda m: got.append(rig.clock.time()) if m.get_type() == "APAD_MODEM_SERIAL"
                    and m.flags & mavlink.SERIAL_CONTROL_FLAG_REPLY else None)
    rig.clock.sleep(MAX_HOLD_MS / 1000 + 1.0)
    assert len(got) == 1 and got[0] - t0 == pytest.approx(MAX_HOLD_MS / 1000 - 0.1, abs=0.2)
