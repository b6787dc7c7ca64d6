"""The aPad's own nanomodem, on its serial port, reached over MAVLink (APAD_MODEM_SERIAL).

The paper's aPads carry nanomodems; the GCS calls an aMussel up through the modem of the aPad that
serves it, so the call-up leaves from the aPad. The GCS's driver speaks to this modem as to a unit of
its own, through our dialect's APAD_MODEM_SERIAL: MAVLink's serial passthrough (SERIAL_CONTROL) with
the target SERIAL_CONTROL lacks, as several aPads share one link.

- Bytes the GCS writes go to the modem at once, as they came (a command's bytes arrive together, as
  the unit needs). Before they go, `before_write` puts the modem where the aPad is now.
- A request with RESPOND asks for the modem's output: it is held until the modem has written
  something, or until its timeout (at most `MAX_HOLD_MS`), and answered with what there is, in
  messages of up to 64 bytes (none at the timeout: one empty reply). A new request replaces a held one.
- Nothing received may end the vehicle: a count beyond the data, a REPLY sent to the aPad, a modem
  port that has gone are dropped and counted by reason in the vehicle's `dropped`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from acoustic.nanomodem.ports import BytePort, PortClosed
from apad_sitl.host import PartHost
from mavlink_dialect import mavlink
from missiontime import US_PER_S, Scheduler, Task
from missiontime.clocks import Doorbell

CHUNK = 64  # APAD_MODEM_SERIAL.data
MAX_HOLD_MS = 10_000  # a request held longer than this is answered (a GCS asking for more is clamped)
IDLE_S = 3600.0  # the deadline task's period while nothing is held (rescheduled when a request is)
REPLY = mavlink.SERIAL_CONTROL_FLAG_REPLY
RESPOND = mavlink.SERIAL_CONTROL_FLAG_RESPOND


@dataclass
class _Held:
    system: int
    component: int
    deadline_us: int


class ModemSerial:
    """The aPad's modem port behind APAD_MODEM_SERIAL; a poller of the vehicle's scheduler (its output)."""

    def __init__(self, host: PartHost, port: BytePort, before_write: Callable[[], None] | None = None) -> None:
        self._host, self.port, self._before_write = host, port, before_write
        self._output = bytearray()  # what the modem wrote and no request has taken yet
        self._held: _Held | None = None
        self._scheduler: Scheduler | None = None
        self._deadline: Task | None = None
        self.gone: str | None = None  # why the modem's port has gone (nothing more is written or read)
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
        if hasattr(self.port, "bell"):
            self.port.bell = bell
            return True
        return False

    def fileno(self) -> int | None:
        return None

    def poll(self) -> bool:
        data = self._read()
        if not data:
            return False
        self._output += data
        if self._held is not None:
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
        if msg.count:
            if self._before_write is not None:
                self._before_write()
            self._write(bytes(msg.data[:msg.count]))
        if msg.flags & RESPOND:
            hold_us = min(msg.timeout, MAX_HOLD_MS) * (US_PER_S // 1000)
            self._held = _Held(msg.get_srcSystem(), msg.get_srcComponent(), host.now_us + hold_us)
            self._output += self._read()
            if self._output or hold_us == 0:
                self._answer()
            elif self._scheduler is not None and self._deadline is not None:
                self._scheduler.reschedule(self._deadline, next_us=self._held.deadline_us, active=True)

    def _on_deadline(self, now_us: int) -> None:
        host = self._host
        host.now_us = max(host.now_us, now_us)
        if self._held is not None and now_us >= self._held.deadline_us:
            self._answer()

    def _answer(self) -> None:
        """Answer the held request with the modem's output (one empty reply if there is none)."""
        held, self._held = self._held, None
        if self._scheduler is not None and self._deadline is not None:
            self._scheduler.reschedule(self._deadline, active=False)
        if held is None:
            return
        out, self._output = bytes(self._output), bytearray()
        for i in range(0, max(len(out), 1), CHUNK):
            chunk = out[i:i + CHUNK]
            self._host.send(mavlink.MAVLink_apad_modem_serial_message(
                held.system, held.component, REPLY, 0, len(chunk), chunk.ljust(CHUNK, b"\0")))

    # ---- the port
    def _write(self, data: bytes) -> None:
        if self.gone is not None:
            self._host.count_unsupported("APAD_MODEM_SERIAL:modem_gone")
            return
        try:
            self.port.write(data)
        except PortClosed as exc:
            self._gone(str(exc))

    def _read(self) -> bytes:
        if self.gone is not None:
            return b""
        try:
            return self.port.read()
        except PortClosed as exc:
            self._gone(str(exc))
            return b""

    def _gone(self, why: str) -> None:
        self.gone = why
        self._host.event("modem_gone", error=why[:200])
