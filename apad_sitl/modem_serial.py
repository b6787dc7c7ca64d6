"""The aPad's own nanomodem, on its serial port, reached over MAVLink (APAD_MODEM_SERIAL).

The paper's aPads carry nanomodems; the GCS calls an aMussel up through the modem of the aPad that
serves it, so the call-up leaves from the aPad. The GCS's driver speaks to this modem as to a unit of
its own, through our dialect's APAD_MODEM_SERIAL: MAVLink's serial passthrough (SERIAL_CONTROL) with
the target SERIAL_CONTROL lacks (several aPads share one link), made whole over a lossy link:

- Writes are numbered (`seq`) and go to the modem once each and in order: a repeat (the link
  duplicated it, or the GCS sent it again) or one that skips a lost one is left for the GCS to send
  again. Before a write goes, `before_write` puts the modem where the aPad is now.
- The modem's output is one stream. A request (RESPOND) says how much of it the GCS holds (`offset`):
  what came before is confirmed and forgotten; the rest is sent again until it is confirmed, at most
  `CHUNKS_PER_ANSWER` messages an answer, each saying where its data begins, where the unconfirmed
  output begins (`base`: what lies before it the GCS will not get), and after which write the modem
  wrote it (`after`: the GCS tells a late answer to an earlier command by it). A request is held
  until there is output, or its timeout (at most `MAX_HOLD_MS`); every answer says which write the
  modem had last (`seq`).
- Bounded: at most `MAX_OUTPUT` bytes of output wait unconfirmed (the oldest lines go first, whole,
  counted).
- One GCS owns the modem: the first to speak to it, until it has been silent `OWNER_SILENT_S`;
  another's messages meanwhile are counted and left alone.
- Nothing received may end the vehicle: a count beyond the data, a REPLY sent to the aPad, a modem
  port that has gone are dropped and counted (the vehicle's `dropped`, or `counts` here).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable
from typing import Any

from acoustic.nanomodem.ports import BytePort, PipeEnd, PortClosed
from apad_sitl.host import PartHost
from mavlink_dialect import mavlink
from missiontime import US_PER_S, Scheduler, Task
from missiontime.clocks import Doorbell

CHUNK = 64  # APAD_MODEM_SERIAL.data
CHUNKS_PER_ANSWER = 4
MAX_OUTPUT = 4096  # bytes of the modem's output waiting to be confirmed
MAX_HOLD_MS = 10_000  # a request held longer than this is answered (a GCS asking for more is clamped)
OWNER_SILENT_S = 10.0  # the owning GCS silent this long: another may take the modem
IDLE_S = 3600.0  # the deadline task's period while nothing is held (rescheduled when a request is)
SEQ_MOD = 1 << 16
REPLY = mavlink.SERIAL_CONTROL_FLAG_REPLY
RESPOND = mavlink.SERIAL_CONTROL_FLAG_RESPOND


def newer(seq: int, than: int) -> bool:
    """Whether write number `seq` comes after `than` (16-bit numbers, wrapping)."""
    return 0 < (seq - than) % SEQ_MOD < SEQ_MOD // 2


def next_seq(seq: int) -> int:
    """The write number after `seq`: 1 .. 65535, then 1 again (0 is "no write yet")."""
    return seq % (SEQ_MOD - 1) + 1


class ModemSerial:
    """The aPad's modem port behind APAD_MODEM_SERIAL; a poller of the vehicle's scheduler (its output)."""

    def __init__(self, host: PartHost, port: BytePort, before_write: Callable[[], None] | None = None) -> None:
        self._host, self.port, self._before_write = host, port, before_write
        self.counts: Counter[str] = Counter()  # what was left alone, and why
        self.gone: str | None = None  # why the modem's port has gone (nothing more is written or read)
        self._owner: tuple[int, int] | None = None  # (system, component) of the GCS the modem answers
        self._owner_heard_us = 0
        self._written = 0  # the last write number given to the modem
        self._base = 0  # where in the output stream `_output` begins
        self._output = bytearray()  # output not yet confirmed
        self._epochs: list[tuple[int, int]] = [(0, 0)]  # (stream position, the write the output from it follows)
        self._held_until_us: int | None = None  # a request held until then (mission time)
        self._scheduler: Scheduler | None = None
        self._deadline: Task | None = None
        host.on(mavlink.MAVLINK_MSG_ID_APAD_MODEM_SERIAL, self._on_serial)

    def attach(self, scheduler: Scheduler, start_us: int, name: str) -> None:
        self._scheduler = scheduler
        self._deadline = scheduler.every(IDLE_S, self._on_deadline, f"{name}.modem", start_us)
        scheduler.reschedule(self._deadline, active=False)
        scheduler.add_poller(self)

    def close(self) -> None:
        if self._scheduler is not None:
            self._scheduler.remove_poller(self)
            if self._deadline is not None:
                self._scheduler.reschedule(self._deadline, active=False)

    # ---- the scheduler's poller: the modem's output
    def ring_on(self, bell: Doorbell) -> bool:
        """An in-process pipe rings the scheduler's doorbell on each write into it (polled only then)."""
        if isinstance(self.port, PipeEnd):
            self.port.bell = bell
            return True
        return False

    def fileno(self) -> int | None:
        return None

    def poll(self) -> bool:
        if not self._take_output():
            return False
        if self._held_until_us is not None:
            self._answer()
        return True

    # ---- the GCS's side
    def _on_serial(self, msg: Any) -> None:
        host = self._host
        if not host.for_us(msg.target_system, msg.target_component):
            return
        if msg.flags & REPLY:
            host.count_invalid("APAD_MODEM_SERIAL", "flags")  # a reply is the aPad's to send
            return
        if not 0 <= msg.count <= CHUNK:
            host.count_invalid("APAD_MODEM_SERIAL", "count")
            return
        sender = (msg.get_srcSystem(), msg.get_srcComponent())
        silent_us = host.now_us - self._owner_heard_us
        if self._owner not in (None, sender) and silent_us < OWNER_SILENT_S * US_PER_S:
            self.counts["not_the_owner"] += 1
            return
        self._owner, self._owner_heard_us = sender, host.now_us
        self._confirm(msg.offset)
        if msg.count:
            if msg.seq == next_seq(self._written):
                self._write(msg.seq, bytes(msg.data[:msg.count]))
            elif newer(msg.seq, self._written):
                self.counts["write_out_of_order"] += 1  # one before it was lost: the GCS sends both again
            else:
                self.counts["repeated_write"] += 1
        if msg.flags & RESPOND:
            self._held_until_us = host.now_us + min(msg.timeout, MAX_HOLD_MS) * (US_PER_S // 1000)
            self._take_output()
            if self._output or msg.timeout == 0:
                self._answer()
            elif self._scheduler is not None and self._deadline is not None:
                self._scheduler.reschedule(self._deadline, next_us=self._held_until_us, active=True)

    def _on_deadline(self, now_us: int) -> None:
        host = self._host
        host.now_us = max(host.now_us, now_us)
        if self._held_until_us is not None and now_us >= self._held_until_us:
            self._answer()

    def _confirm(self, offset: int) -> None:
        """The GCS holds the output up to `offset`: forget it. An offset past the output's end confirms
        it all (the GCS took bytes the modem never wrote: a spoof; its next answer says where the stream
        stands, and the GCS goes back there); one before what waits changes nothing."""
        end = self._base + len(self._output)
        if offset > end:
            self.counts["offset_past_output"] += 1
        if self._base < offset:
            self._forget(min(offset, end) - self._base)

    def _forget(self, n: int) -> None:
        del self._output[:n]
        self._base += n
        while len(self._epochs) > 1 and self._epochs[1][0] <= self._base:
            self._epochs.pop(0)

    def _answer(self) -> None:
        """Answer the held request: the unconfirmed output, from where it begins (none: one empty message)."""
        self._held_until_us = None
        if self._scheduler is not None and self._deadline is not None:
            self._scheduler.reschedule(self._deadline, active=False)
        owner = self._owner
        if owner is None:
            return
        base, end = self._base, self._base + len(self._output)
        position = base
        for _ in range(CHUNKS_PER_ANSWER):
            after, epoch_end = self._epoch_at(position)
            stop = min(end, position + CHUNK, epoch_end)
            chunk = bytes(self._output[position - base:stop - base])
            self._host.send(mavlink.MAVLink_apad_modem_serial_message(
                owner[0], owner[1], REPLY, 0, self._written, position, base, after, len(chunk),
                chunk.ljust(CHUNK, b"\0")))
            position = stop
            if position >= end:
                break

    def _epoch_at(self, position: int) -> tuple[int, int]:
        """After which write the output at `position` was written, and where the next write's output begins."""
        after, end = self._epochs[0][1], 1 << 62
        for start, seq in self._epochs:
            if start > position:
                end = start
                break
            after = seq
        return after, end

    # ---- the port
    def _write(self, seq: int, data: bytes) -> None:
        self._take_output()  # what the modem wrote before this command follows the write before
        self._written = seq
        here = self._base + len(self._output)
        if self._epochs[-1][0] == here:  # nothing written since the last write: this one's replaces it (bounded)
            self._epochs[-1] = (here, seq)
        else:
            self._epochs.append((here, seq))
        if self.gone is not None:
            self._host.count_unsupported("APAD_MODEM_SERIAL:modem_gone")
            return
        if self._before_write is not None:
            self._before_write()
        try:
            self.port.write(data)
        except PortClosed as exc:
            self._gone(str(exc))

    def _take_output(self) -> bool:
        """The modem's new output into the stream (the oldest beyond `MAX_OUTPUT` forgotten, counted)."""
        if self.gone is not None:
            return False
        try:
            data = self.port.read()
        except PortClosed as exc:
            self._gone(str(exc))
            return False
        self._output += data
        if len(self._output) > MAX_OUTPUT:
            # The oldest lines go whole (to the end of the line the bound cuts), so what is left, and
            # the GCS's parser, begin at a reply's start.
            cut = self._output.find(b"\r\n", len(self._output) - MAX_OUTPUT)
            over = len(self._output) if cut < 0 else cut + 2
            self.counts["output_overflow"] += over
            self._forget(over)
        return bool(data)

    def _gone(self, why: str) -> None:
        self.gone = why
        self._host.event("modem_gone", error=why[:200])
