"""The emulator on an in-process pipe, run by a mission clock (lockstep runs, tests).

`attach` makes the emulator a receive poller of the clock's scheduler (what the driver writes rings
the scheduler's doorbell, so it is handed over at the instant it was written, and nothing is polled
otherwise) and a task rescheduled to the emulator's next instant of its own (a reception's end, a
ping's timeout, a command's gap). The driver on the pipe's other end, on the same clock, waits with
`clock.sleep`, which runs both: no thread, no pty, no idle ticking, and the same seed gives the same
bytes.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from acoustic.nanomodem.emulator import ModemEmulator
from acoustic.nanomodem.ports import PipeEnd, PortClosed
from acoustic.nanomodem.sea import Heard
from missiontime.clocks import Clock, Doorbell, Task, seconds_to_us, us_to_s

IDLE_S = 3600.0  # the task's period while the emulator has nothing due (it is rescheduled when it has)


class Attached:
    """The emulator's side of the pipes, on a clock: `port` the local unit's, `hosted[i]` hosted unit
    i + 1's (`ModemEmulator`'s `hosted`: an aPad's own modem)."""

    def __init__(self, core: ModemEmulator, port: PipeEnd, clock: Clock, hosted: tuple[PipeEnd, ...] = ()) -> None:
        if len(hosted) != len(core.units) - 1:
            raise ValueError(f"{len(core.units) - 1} hosted units, {len(hosted)} ports")
        self.core, self.clock = core, clock
        self.ports = (port, *hosted)
        self.gone: set[PipeEnd] = set()  # ports whose other end has closed
        self.task: Task = clock.scheduler.every(IDLE_S, self._due, "nanomodem emulator", start_us=clock.now_us)
        clock.scheduler.add_poller(self)

    def ring_on(self, bell: Doorbell) -> bool:
        for port in self.ports:
            port.bell = bell
        return True

    def fileno(self) -> int | None:
        return None

    def poll(self) -> bool:
        arrived = [(unit, data) for unit, port in enumerate(self.ports) if (data := self._read(port))]
        if not arrived:
            return False
        now = us_to_s(self.clock.now_us)
        self.core.run_to(now)  # what was due before these bytes (written below, before what they cause)
        for unit, data in arrived:
            self.core.from_host(data, now, unit)
        self.core.run_to(now)
        self._send()
        return True

    def remote_send(self, address: int, data: bytes, dest: int | None = None) -> None:
        """Remote unit `address` sends now (a broadcast, or a unicast to `dest`): the emulator's
        `remote_send`, with its next instant rescheduled."""
        self.core.remote_send(address, us_to_s(self.clock.now_us), data, dest)
        self._send()

    # ---- the `Sea` of the remote units (acoustic.nanomodem.sea), in-process
    def send(self, address: int, data: bytes, dest: int | None) -> None:
        self.remote_send(address, data, dest)

    def move(self, addresses: list[int], positions_m: NDArray[np.float64]) -> None:
        self.core.move_remotes(addresses, positions_m)

    def power(self, powered: dict[int, bool]) -> None:
        self.core.set_power(powered)

    def listen(self, heard: Heard) -> None:
        self.core.on_remote_heard = lambda _t_s, address, frame: heard(address, frame.kind, frame.data)

    def _due(self, now_us: int) -> None:
        self.core.run_to(us_to_s(now_us))
        self._send()

    def _read(self, port: PipeEnd) -> bytes:
        if port in self.gone:
            return b""
        try:
            return port.read()
        except PortClosed:
            self._gone(port)
            return b""

    def _gone(self, port: PipeEnd) -> None:
        """A host that has gone (an aPad's modem cable pulled): its unit hears on, its bytes go nowhere."""
        self.gone.add(port)
        self.core.count("host_gone")

    def _send(self) -> None:
        """Each unit's output to its host, and the emulator's next instant rescheduled."""
        for unit, port in enumerate(self.ports):
            out = self.core.take_output(unit)
            if out and port not in self.gone:
                try:
                    port.write(out)
                except PortClosed:
                    self._gone(port)
        due = self.core.next_due_s()
        sched = self.clock.scheduler
        if due is None:
            sched.reschedule(self.task, active=False)
        else:
            due_us = seconds_to_us(due)
            if us_to_s(due_us) < due:  # rounded down: at that microsecond it would not yet be due, and spin
                due_us += 1
            sched.reschedule(self.task, next_us=max(due_us, self.clock.now_us), active=True)


def attach(core: ModemEmulator, port: PipeEnd, clock: Clock, hosted: tuple[PipeEnd, ...] = ()) -> Attached:
    return Attached(core, port, clock, hosted)
