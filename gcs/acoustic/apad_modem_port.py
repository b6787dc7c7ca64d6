"""One aPad's own nanomodem as a byte port for the GCS's driver, through the link (APAD_MODEM_SERIAL).

The same `ModemDriver` that speaks to the GCS's unit on its serial port speaks to an aPad's unit this
way (`apad_sitl.modem_serial` is the aPad's side). `write` sends the bytes to the aPad in messages of
up to 64 bytes, asking for the modem's output back; `read` returns what the aPad has sent back and
keeps one request outstanding, held by the aPad until its modem writes or `HOLD_MS` pass: a driver
that looks every few milliseconds costs the link a message per answer, not per look. A request
unanswered `LATE_S` past its hold is asked again (the link may have lost it or its answer). A reply
that does not fit is dropped and counted (`dropped`).
"""

from __future__ import annotations

from collections import Counter
from typing import Any

from acoustic.nanomodem.ports import PortClosed
from gcs.link.router import Link
from mavlink_dialect import mavlink
from missiontime import Clock, seconds_to_us

CHUNK = 64  # APAD_MODEM_SERIAL.data
HOLD_MS = 1000  # how long the aPad may hold a request for output
LATE_S = 1.0  # past its hold by this much, a request is taken as lost and asked again
REPLY = mavlink.SERIAL_CONTROL_FLAG_REPLY
RESPOND = mavlink.SERIAL_CONTROL_FLAG_RESPOND


class ApadModemPort:
    """A `BytePort` to the modem of aPad `apad_id`, over `link`."""

    def __init__(self, link: Link, apad_id: int, clock: Clock) -> None:
        self._link, self.apad_id, self._clock = link, apad_id, clock
        self._inbox = bytearray()
        self._asked_us: int | None = None  # when the outstanding request went; None: none outstanding
        self.dropped: Counter[str] = Counter()
        self.requests = 0  # APAD_MODEM_SERIAL messages sent (writes and requests for output)
        self.closed = False
        link.attach(self._on_message)

    def write(self, data: bytes) -> None:
        if self.closed:
            raise PortClosed(f"aPad {self.apad_id}'s modem: closed")
        for i in range(0, len(data), CHUNK):
            chunk = data[i:i + CHUNK]
            last = i + CHUNK >= len(data)
            self._send(chunk, RESPOND if last else 0)

    def read(self) -> bytes:
        if self.closed:
            raise PortClosed(f"aPad {self.apad_id}'s modem: closed")
        asked = self._asked_us
        if asked is None or self._clock.now_us - asked > seconds_to_us(HOLD_MS / 1000 + LATE_S):
            if asked is not None:
                self.dropped["request_unanswered"] += 1
            self._send(b"", RESPOND)
        out, self._inbox = bytes(self._inbox), bytearray()
        return out

    def close(self) -> None:
        self.closed = True

    def _send(self, chunk: bytes, flags: int) -> None:
        self.requests += 1
        if flags & RESPOND:
            self._asked_us = self._clock.now_us
        self._link.send(mavlink.MAVLink_apad_modem_serial_message(
            self.apad_id, 0, flags, HOLD_MS, len(chunk), chunk.ljust(CHUNK, b"\0")))

    def _on_message(self, msg: Any) -> None:
        if msg.get_msgId() != mavlink.MAVLINK_MSG_ID_APAD_MODEM_SERIAL or msg.get_srcSystem() != self.apad_id:
            return
        if not msg.flags & REPLY or msg.target_system not in (0, self._link.codec.system_id):
            return  # a request (ours, as the link hands it round), or an answer to another GCS
        if not 0 <= msg.count <= CHUNK:
            self.dropped["invalid_count"] += 1
            return
        if not self.closed:
            self._inbox += bytes(msg.data[:msg.count])
        self._asked_us = None
