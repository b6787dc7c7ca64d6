"""An aPad's own nanomodem reached over MAVLink: the GCS's driver through `ApadModemPort`, the
aPad's `ModemSerial` on its SITL, real MAVLink bytes between them (an in-memory pair on one virtual
clock), the emulator's water beyond."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from acoustic.nanomodem.driver import ModemDriver, Outcome
from acoustic.nanomodem.emulator import FrameKind, ModemEmulator, RemoteUnit
from acoustic.nanomodem.host_commands import Command, Kind
from acoustic.nanomodem.lockstep import attach
from acoustic.nanomodem.ports import pipe
from acoustic.nanomodem.replies import Range, Status
from acoustic.params import AcousticParams
from apad_sitl.endpoint import SitlVehicle
from apad_sitl.modem_serial import CHUNKS_PER_ANSWER, MAX_HOLD_MS
from apad_sitl.params import ApadParams
from gcs.acoustic_net.apad_modem_port import HOLD_MS, LATE_S, MAX_INBOX, ApadModemPort
from gcs.link.router import Link
from mavlink_dialect import Codec, mavlink, memory_pair
from missiontime import VirtualClock

HOME = (43.9400, 15.4400)
MUSSEL = RemoteUnit(7, (30.0, 0.0, 3.0))
UNIT = 255


class Rig:
    def __init__(self) -> None:
        self.clock = clock = VirtualClock()
        self.link = Link(clock)
        gcs_end, apad_end = memory_pair("apad1")
        self.apad_end = apad_end  # what the aPad sends goes through here to the GCS (a test may send in its name)
        self.link.add_transport(gcs_end)
        _, gcs_modem = pipe()
        modem_port, water_end = pipe()
        self.core = ModemEmulator(AcousticParams(), (MUSSEL,), np.random.default_rng(1),
                                  hosted=(RemoteUnit(UNIT, (0.0, 0.0, 0.5)),))
        self.water = attach(self.core, gcs_modem, clock, hosted=(water_end,))
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
             "timeout": 0, "seq": 0, "offset": 0, "base": 0, "after": 0, "count": 0, "data": bytes(64), **fields}
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
    before = rig.port.sent
    t0 = rig.clock.time()
    assert rig.port.read() == b""  # asks; the aPad holds the request
    while rig.clock.time() - t0 < 10 * HOLD_MS / 1000:
        assert rig.port.read() == b""
        rig.clock.sleep(0.005)  # the driver's pace
    assert 9 <= rig.port.sent - before <= 11  # about one request per hold, not one per look
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
    rig.clock.sleep(HOLD_MS / 1000 + LATE_S / 2)
    rig.port.read()
    assert rig.port.dropped == {}  # within its hold and the margin: still waited for
    rig.clock.sleep(LATE_S)
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


def test_a_late_answer_is_not_taken_as_the_next_commands() -> None:
    rig = Rig()
    rig.core.set_power({7: False})  # the aMussel will not answer: the unit says #TO after 4 s
    rig.driver.send(Command(Kind.PING, 7))  # a ping whose wait was cut short
    rig.clock.sleep(10.0)  # nobody reads meanwhile: the #TO waits on the aPad
    assert rig.driver.status().ok  # not the ping's #TO
    assert rig.port.dropped["late_output"] > 0


def test_output_waiting_on_the_apad_is_bounded_and_goes_back_a_few_messages_at_a_time() -> None:
    rig = Rig()
    assert rig.driver.status().ok
    for _ in range(150):  # the aMussel broadcasts and the aPad's modem hears it all, while nobody reads
        rig.water.remote_send(7, b"B" * 48)
        rig.clock.sleep(1.0)
    modem = rig.vehicle.modem
    assert modem is not None and modem.counts["output_overflow"] > 0
    got: list[int] = []
    rig.link.attach(lambda m: got.append(m.count) if m.get_type() == "APAD_MODEM_SERIAL"
                    and m.flags & mavlink.SERIAL_CONTROL_FLAG_REPLY else None)
    rig.send(seq=1, timeout=1000)
    assert got == [64] * CHUNKS_PER_ANSWER
    assert rig.driver.status().ok  # the port goes on from where the aPad's output now begins
    assert rig.port.dropped["output_skipped"] > 0


def test_writes_are_written_once_and_output_lost_on_the_way_is_sent_again() -> None:
    rig = Rig()
    rig.send(seq=1, count=2, data=b"$?".ljust(64, b"\0"))
    rig.send(seq=1, count=2, data=b"$?".ljust(64, b"\0"))  # the link repeated it
    modem = rig.vehicle.modem
    assert modem is not None and modem.counts["repeated_write"] == 1 and rig.core.counts["command"] == 1
    replies: list[tuple[int, int]] = []
    rig.link.attach(lambda m: replies.append((m.offset, m.count)) if m.get_type() == "APAD_MODEM_SERIAL"
                    and m.flags & mavlink.SERIAL_CONTROL_FLAG_REPLY else None)
    rig.send(seq=1, offset=0, timeout=1000)  # as if the answers so far were lost: from 0 again
    rig.send(seq=1, offset=0, timeout=1000)
    assert replies[-1][0] == 0 and replies[-1][1] > 0 and replies[-1] == replies[-2]  # resent until confirmed
    rig.send(seq=1, offset=replies[-1][1], timeout=0)  # confirmed: nothing more waits
    assert replies[-1] == (replies[-2][1], 0)


def test_the_gcs_port_keeps_what_it_has_not_read_bounded() -> None:
    rig = Rig()
    rig.port.read()
    codec = Codec(1, 1)  # a hostile stream in the aPad's name: valid frames, each continuing the last
    offset = 0
    for _ in range(200):
        frame = mavlink.MAVLink_apad_modem_serial_message(
            rig.link.codec.system_id, 0, mavlink.SERIAL_CONTROL_FLAG_REPLY, 0, 0, offset, offset, 0, 64,
            b"#B007".ljust(62, b"x") + b"\r\n")
        rig.apad_end.send(codec.encode(frame))
        offset += 64
    rig.clock.sleep(0.01)
    assert rig.port.dropped["inbox_full"] > 0 and len(rig.port.read()) <= MAX_INBOX


def test_another_gcs_cannot_take_the_apads_modem_while_its_owner_speaks() -> None:
    rig = Rig()
    assert rig.driver.status().ok  # the GCS owns the modem now
    stranger = Codec(200, 190)
    for seq in (1, 2):
        rig.apad_end.peer.send(stranger.encode(mavlink.MAVLink_apad_modem_serial_message(  # type: ignore[union-attr]
            1, 0, mavlink.SERIAL_CONTROL_FLAG_RESPOND, 1000, seq, 0, 0, 0, 2, b"$?".ljust(64, b"\0"))))
        rig.clock.sleep(0.1)
    modem = rig.vehicle.modem
    assert modem is not None and modem.counts["not_the_owner"] == 2
    assert rig.driver.status().ok


def test_a_spoofed_write_number_or_stream_position_is_caught_up_with() -> None:
    rig = Rig()
    assert rig.driver.status().ok
    rig.send(seq=20_000, count=2, data=b"$?".ljust(64, b"\0"))  # in the GCS's name, numbered far ahead
    modem = rig.vehicle.modem
    assert modem is not None and modem.counts["write_out_of_order"] == 1  # not written: writes go in order
    assert rig.driver.status().ok
    codec = Codec(1, 1)  # output the modem never wrote, in the aPad's name, where the stream stands
    rig.apad_end.send(codec.encode(mavlink.MAVLink_apad_modem_serial_message(
        rig.link.codec.system_id, 0, mavlink.SERIAL_CONTROL_FLAG_REPLY, 0, 2, 10_000, 10_000, 2, 5,
        b"junk!".ljust(64, b"\0"))))
    rig.clock.sleep(0.1)
    assert rig.port.dropped["output_skipped"] > 0  # believed: the port now holds bytes the modem never wrote
    # The next command's answer is confirmed away by the position the spoof gave the port (it costs that
    # command); two empty answers later the port has gone back to where the aPad's stream stands.
    assert rig.driver.status().outcome is Outcome.NO_REPLY
    assert rig.port.dropped["stream_resync"] == 1
    assert rig.driver.status().ok


def test_a_stream_position_past_the_fields_range_is_refused_not_packed() -> None:
    rig = Rig()
    assert rig.driver.status().ok
    codec = Codec(1, 1)
    rig.apad_end.send(codec.encode(mavlink.MAVLink_apad_modem_serial_message(
        rig.link.codec.system_id, 0, mavlink.SERIAL_CONTROL_FLAG_REPLY, 0, 1, 0xFFFF_FFF0, 0xFFFF_FFF0, 1, 64,
        b"#".ljust(64, b"x"))))
    rig.clock.sleep(0.1)
    assert rig.port.dropped["invalid_reply"] == 1
    assert rig.driver.status().ok  # its next request still packs
