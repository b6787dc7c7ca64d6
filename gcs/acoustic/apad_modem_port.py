"""One aPad's own nanomodem as a byte port for the GCS's driver, through the link (APAD_MODEM_SERIAL).

The same `ModemDriver` that speaks to the GCS's unit on its serial port speaks to an aPad's unit this
way (`apad_sitl.modem_serial` is the aPad's side, and says what the message's fields mean).

- `write` numbers the bytes (in messages of up to 64) and asks for the modem's output with each; a
  write the aPad has not shown it took within `HOLD_MS` and `LATE_S` is sent again (the aPad writes
  a repeat only once).
- `read` returns the output that came back in order, and keeps one request outstanding, held by the
  aPad until its modem writes or `HOLD_MS` pass: a driver that looks every few milliseconds costs the
  link a message per answer, not per look. Each request confirms the output held so far, so output
  lost on the way is sent again; output seen twice is taken once.
- Output the modem wrote before the last write reached it is a late answer to an earlier command: it
  is dropped and counted (`late_output`), never taken as the new command's answer.
- Bounded: at most `MAX_INBOX` bytes wait unread (the rest counted, `inbox_full`); unsent writes at
  most `MAX_UNCONFIRMED`. What does not fit is counted by reason in `dropped`.
"""

from __future__ import annotations

from collections import Counter, deque
from typing import Any

from acoustic.nanomodem.ports import PortClosed
from apad_sitl.modem_serial import CHUNK, REPLY, RESPOND, SEQ_MOD, newer
from gcs.link.router import Link
from mavlink_dialect import mavlink
from missiontime import Clock, seconds_to_us

HOLD_MS = 250  # how long the aPad may hold a request for output
LATE_S = 0.25  # past its hold by this much, a request (or a write) is taken as lost and sent again
MAX_INBOX = 4096  # bytes of output waiting for the driver
MAX_UNCONFIRMED = 64  # writes kept for sending again until the aPad shows it took them


class ApadModemPort:
    """A `BytePort` to the modem of aPad `apad_id`, over `link`."""

    def __init__(self, link: Link, apad_id: int, clock: Clock) -> None:
        self._link, self.apad_id, self._clock = link, apad_id, clock
        self._inbox = bytearray()
        self._received = 0  # how much of the modem's output stream has come back
        self._synced = False  # the stream's position taken from the aPad's first answer
        self._seq = 0  # the last write number given
        self._taken = 0  # the last write the aPad has shown it gave its modem
        self._unconfirmed: deque[tuple[int, bytes]] = deque()  # (write number, bytes) not shown taken
        self._asked_us: int | None = None  # when the outstanding request went; None: none outstanding
        self.dropped: Counter[str] = Counter()
        self.sent = 0  # APAD_MODEM_SERIAL messages sent (writes, requests, their repeats)
        self.closed = False
        link.attach(self._on_message)

    def write(self, data: bytes) -> None:
        if self.closed:
            raise PortClosed(f"aPad {self.apad_id}'s modem: closed")
        for i in range(0, len(data), CHUNK):
            self._seq = self._seq % (SEQ_MOD - 1) + 1  # 1 .. 65535, then 1 again (0: no write yet)
            if len(self._unconfirmed) == MAX_UNCONFIRMED:
                self._unconfirmed.popleft()
                self.dropped["unconfirmed_full"] += 1
            self._unconfirmed.append((self._seq, data[i:i + CHUNK]))
            self._send(self._seq, data[i:i + CHUNK])

    def read(self) -> bytes:
        if self.closed:
            raise PortClosed(f"aPad {self.apad_id}'s modem: closed")
        asked = self._asked_us
        if asked is None:
            self._send(self._seq, b"")
        elif self._clock.now_us - asked > seconds_to_us(HOLD_MS / 1000 + LATE_S):
            self.dropped["request_unanswered"] += 1  # it, or its answer, was lost
            for seq, chunk in self._unconfirmed:  # writes not shown taken go again (the aPad writes each once)
                self._send(seq, chunk)
            if not self._unconfirmed:
                self._send(self._seq, b"")
        out, self._inbox = bytes(self._inbox), bytearray()
        return out

    def close(self) -> None:
        self.closed = True

    def _send(self, seq: int, chunk: bytes) -> None:
        self.sent += 1
        self._asked_us = self._clock.now_us
        self._link.send(mavlink.MAVLink_apad_modem_serial_message(
            self.apad_id, 0, RESPOND, HOLD_MS, seq, self._received, len(chunk), chunk.ljust(CHUNK, b"\0")))

    def _renumber(self, taken: int) -> None:
        """The aPad's last write is `taken`, past ours: the writes it has not shown taken (it counted them
        as repeats) go again, numbered on from there."""
        pending, self._unconfirmed = list(self._unconfirmed), deque()
        self._seq = self._taken = taken
        for _, chunk in pending:
            self._seq = self._seq % (SEQ_MOD - 1) + 1
            self._unconfirmed.append((self._seq, chunk))
            self._send(self._seq, chunk)

    def _on_message(self, msg: Any) -> None:
        if msg.get_msgId() != mavlink.MAVLINK_MSG_ID_APAD_MODEM_SERIAL or msg.get_srcSystem() != self.apad_id:
            return
        if not msg.flags & REPLY or msg.target_system not in (0, self._link.codec.system_id):
            return  # a request (ours, as the link hands it round), or an answer to another GCS
        if not 0 <= msg.count <= CHUNK:
            self.dropped["invalid_count"] += 1
            return
        self._asked_us = None
        if newer(msg.seq, self._seq):  # the aPad took a write numbered past ours (a spoof): ours go on from there
            self.dropped["seq_resync"] += 1
            self._renumber(msg.seq)
        elif newer(msg.seq, self._taken):
            self._taken = msg.seq
        while self._unconfirmed and not newer(self._unconfirmed[0][0], self._taken):
            self._unconfirmed.popleft()
        if not self._synced:  # the first answer says where the stream stands (a new GCS, an older aPad)
            self._received, self._synced = msg.offset, True
        if msg.count == 0 and msg.offset < self._received:  # we hold bytes the modem never wrote (a spoof)
            self.dropped["stream_resync"] += 1
            self._received = msg.offset
        start, data = msg.offset, bytes(msg.data[:msg.count])
        if start > self._received:
            self.dropped["output_gap"] += 1  # what came before it was lost: asked again from there
            return
        fresh = data[self._received - start:]
        self._received += len(fresh)
        if not fresh:
            return
        if msg.seq != self._seq:
            self.dropped["late_output"] += len(fresh)  # written before our last command reached the modem
        elif len(self._inbox) + len(fresh) > MAX_INBOX:
            self.dropped["inbox_full"] += len(fresh)
        elif not self.closed:
            self._inbox += fresh
