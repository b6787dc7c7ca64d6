"""The emulator on an in-process pipe, stepped by a mission clock's scheduler (lockstep runs, tests).

`attach` registers one periodic task: it hands the emulator what the driver wrote (arrived at the
task's instant), runs it to that instant and writes its answers back. The driver on the pipe's other
end, on the same clock, waits with `clock.sleep`, which runs the task: no thread, no pty, and the
same seed gives the same bytes.
"""

from __future__ import annotations

from acoustic.nanomodem.emulator import ModemEmulator
from acoustic.nanomodem.ports import BytePort
from missiontime.clocks import Scheduler, Task, us_to_s

STEP_S = 0.005  # the driver's own poll: a command written in one piece arrives in one piece


def attach(core: ModemEmulator, port: BytePort, scheduler: Scheduler, step_s: float = STEP_S) -> Task:
    def step(now_us: int) -> None:
        now = us_to_s(now_us)
        out = core.advance(now)
        data = port.read()
        if data:
            core.from_host(data, now)
            out += core.advance(now)
        if out:
            port.write(out)

    return scheduler.every(step_s, step, "nanomodem emulator")
