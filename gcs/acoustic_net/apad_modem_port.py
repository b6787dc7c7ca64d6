"""One aPad's own nanomodem as a byte port for the GCS's driver, through the link (APAD_MODEM_SERIAL).

The same `ModemDriver` that speaks to the GCS's unit on its serial port speaks to an aPad's unit this
way (`apad_sitl.modem_serial` is the aPad's side, and says what the message's fields mean).

- `write` numbers the bytes (in messages of up to 64) and asks for the modem's output with each. A
  write the aPad has not shown it took (each answer says which it took last) is sent again, with those
  after it, every `HOLD_MS` + `LATE_S`; the aPad writes each number once and in order.
- `read` returns the output that came back in order, and keeps one request outstanding, held by the
  aPad until its modem writes or `HOLD_MS` pass: a driver that looks every few milliseconds costs the
  link a message per answer, not per look. Each request confirms the output held so far; output lost
  on the way is sent again, output seen twice is taken once, and where the aPad says its output now
  begins past what came back (it dropped a late answer, or its bound overflowed) the port goes on from
  there (`output_skipped`, counted): the stream moves forward only, but for one case. Where two
  answers in a row, with every write taken, say the aPad's output ends before what the port holds,
  the port holds bytes the modem never wrote (a reply spoofed in the aPad's name) and goes back there
  (`stream_resync`); a single such answer is a late one the link delayed, and left alone.
- Output the modem wrote after an earlier write than the port's last (`after`) is a late answer to an
  earlier command (the driver writes only when it is done waiting): dropped and counted
  (`late_output`), never taken as the new command's.
- The driver is handed whole lines (every reply of the unit ends CR LF): the end of a line still on
  its way waits here, so a line cut by a loss or a late drop never runs into the next reply in the
  driver's parser (the cut part counted, `cut_line`).
- Bounded: at most `MAX_INBOX` bytes wait unread (the rest counted, `inbox_full`); unconfirmed writes
  at most `MAX_UNCONFIRMED`. What does not fit is counted by reason in `dropped`.
"""

from __future__ import annotations

from collections import Counter, deque
from typing import Any

from acoustic.nanomodem.ports import PortClosed
from apad_sitl.modem_serial import CHUNK, REPLY, RESPOND, newer, next_seq
from gcs.link.router import Link
from mavlink_dialect import mavlink
from missiontime import Clock, seconds_to_us

HOLD_MS = 250  # how long the aPad may hold a request for output
LATE_S = 0.25  # past its hold by this much, a request (or a write) is taken as lost and sent again
MAX_INBOX = 4096  # bytes of output waiting for the driver
MAX_UNCONFIRMED = 64  # writes kept for sending again until the aPad shows it took them
STREAM_MAX = 0xFFFF_FFFF  # APAD_MODEM_SERIAL.offset is a uint32 (4 GB of a modem's output)


class ApadModemPort:
    """A `BytePort` to the modem of aPad `apad_id`, over `link`."""

    def __init__(self, link: Link, apad_id: int, clock: Clock) -> None:
        self._link, self.apad_id, self._clock = link, apad_id, clock
        self._inbox = bytearray()  # whole lines for the driver
        self._partial = bytearray()  # the start of a line whose end has not come
        self._received = 0  # how far into the modem's output stream we hold (it only moves forward)
        self._seq = 0  # the last write number given
        self._taken = 0  # the last write the aPad has shown it gave its modem
        self._unconfirmed: deque[tuple[int, bytes]] = deque()  # (write number, bytes) not shown taken
        self._resend_us: int | None = None  # when the unconfirmed writes go again
        self._asked_us: int | None = None  # when the outstanding request went; None: none outstanding
        self._older_since: int | None = None  # since when every answer has been older than `_taken`
        self._behind = 0  # answers in a row that said the aPad's output ends before what we hold
        self.dropped: Counter[str] = Counter()
        self.sent = 0  # APAD_MODEM_SERIAL messages sent (writes, requests, their repeats)
        self.closed = False
        link.attach(self._on_message)

    def write(self, data: bytes) -> None:
        if self.closed:
            raise PortClosed(f"aPad {self.apad_id}'s modem: closed")
        for i in range(0, len(data), CHUNK):
            self._seq = next_seq(self._seq)
            if len(self._unconfirmed) == MAX_UNCONFIRMED:
                self._unconfirmed.popleft()
                self.dropped["unconfirmed_full"] += 1
            self._unconfirmed.append((self._seq, data[i:i + CHUNK]))
            self._send(self._seq, data[i:i + CHUNK])
        self._resend_us = self._clock.now_us + self._patience_us()

    def read(self) -> bytes:
        if self.closed:
            raise PortClosed(f"aPad {self.apad_id}'s modem: closed")
        now = self._clock.now_us
        if self._unconfirmed and self._resend_us is not None and now >= self._resend_us:
            self.dropped["write_resent"] += 1  # it, or every answer since, was lost: in order, from it
            for seq, chunk in self._unconfirmed:
                self._send(seq, chunk)
            self._resend_us = now + self._patience_us()
        elif self._asked_us is None:
            self._send(self._seq, b"")
        elif now - self._asked_us > self._patience_us():
            self.dropped["request_unanswered"] += 1  # it, or its answer, was lost
            self._send(self._seq, b"")
        out, self._inbox = bytes(self._inbox), bytearray()
        return out

    def close(self) -> None:
        self.closed = True

    @staticmethod
    def _patience_us() -> int:
        return seconds_to_us(HOLD_MS / 1000 + LATE_S)

    def _send(self, seq: int, chunk: bytes) -> None:
        self.sent += 1
        self._asked_us = self._clock.now_us
        self._link.send(mavlink.MAVLink_apad_modem_serial_message(
            self.apad_id, 0, RESPOND, HOLD_MS, seq, self._received, 0, 0, len(chunk), chunk.ljust(CHUNK, b"\0")))

    def _follow(self, taken: int) -> None:
        """The aPad's last write is `taken`: the writes up to it are done with; the rest must follow it in
        order. An answer older than one already had is a late one, left alone (believed only when nothing
        else has come for twice the patience: a spoof had moved the count on). A number past every one
        given here is a restarted GCS's count or a spoof: the pending writes go again numbered on from
        it. The aPad writes a number once, so none is written twice."""
        now = self._clock.now_us
        if self._taken and newer(self._taken, taken):  # older than an answer already had: a late one
            if self._older_since is None:
                self._older_since = now
            if now - self._older_since < 2 * self._patience_us():
                self.dropped["late_seq"] += 1
                return  # (only such answers, for longer: believed, below; a spoof had moved _taken)
        self._older_since = None
        if newer(taken, self._seq):  # past every number given here: a restarted GCS's, or a spoof
            self.dropped["seq_resync"] += 1
            if self._unconfirmed:
                self._renumber(taken)  # none of them can have been written
            else:
                self._seq = taken
            return
        self._taken = taken
        while self._unconfirmed and not newer(self._unconfirmed[0][0], taken):
            self._unconfirmed.popleft()
            self._resend_us = self._clock.now_us + self._patience_us()
        if self._unconfirmed and self._unconfirmed[0][0] != next_seq(taken):  # a spoof moved the numbers
            self.dropped["seq_resync"] += 1
            self._renumber(taken)

    def _renumber(self, taken: int) -> None:
        """The writes the aPad has not shown taken go again, numbered on from `taken`."""
        pending, self._unconfirmed = list(self._unconfirmed), deque()
        self._seq = taken
        for _, chunk in pending:
            self._seq = next_seq(self._seq)
            self._unconfirmed.append((self._seq, chunk))
            self._send(self._seq, chunk)

    def _on_message(self, msg: Any) -> None:
        if msg.get_msgId() != mavlink.MAVLINK_MSG_ID_APAD_MODEM_SERIAL or msg.get_srcSystem() != self.apad_id:
            return
        if not msg.flags & REPLY or msg.target_system not in (0, self._link.codec.system_id):
            return  # a request (ours, as the link hands it round), or an answer to another GCS
        if not 0 <= msg.count <= CHUNK or msg.offset < msg.base or msg.offset + msg.count > STREAM_MAX:
            self.dropped["invalid_reply"] += 1  # (a stream position past the field's range could not be asked for)
            return
        self._asked_us = None
        self._follow(msg.seq)
        if msg.base > self._received:  # what lies before it will not come: past the aPad's bound
            self.dropped["output_skipped"] += msg.base - self._received
            self._received = msg.base
            self._cut()
        ends_behind = msg.count == 0 and msg.base < self._received and msg.seq == self._seq == self._taken
        self._behind = self._behind + 1 if ends_behind else 0
        if self._behind == 2:
            self.dropped["stream_resync"] += 1
            self._received, self._behind = msg.base, 0
            self._cut()
        start, data = msg.offset, bytes(msg.data[:msg.count])
        if start > self._received:
            self.dropped["output_gap"] += 1  # an earlier message of the answer was lost: sent again
            return
        fresh = data[self._received - start:]
        self._received += len(fresh)
        if not fresh:
            return
        if msg.after != self._seq:
            self.dropped["late_output"] += len(fresh)
            self._cut()  # the line begun was late too
            return
        self._partial += fresh
        last = self._partial.rfind(b"\r\n")
        end = last + 2 if last >= 0 else 0
        lines, self._partial = self._partial[:end], self._partial[end:]
        if len(self._partial) > MAX_INBOX:  # no line ends: not the unit's output
            self._cut()
        if len(self._inbox) + len(lines) > MAX_INBOX:
            self.dropped["inbox_full"] += len(lines)
        elif not self.closed:
            self._inbox += lines

    def _cut(self) -> None:
        if self._partial:
            self.dropped["cut_line"] += len(self._partial)
            self._partial = bytearray()
