"""The MAVLink command protocol, GCS side: send, wait for the COMMAND_ACK, retry with backoff.

Waits run on the clock (`clock.sleep`), so the same client serves lockstep runs and the field.
Every wait is bounded: `retries + 1` attempts, the first waiting `timeout_s` and each next one
`BACKOFF` times the one before (1 + 1.5 + 2.25 + 3.375 s by default); at the bound a
`CommandError` with `result=None`. A vehicle that answers IN_PROGRESS gets at most
`IN_PROGRESS_MAX_S` in all before the command fails with that result.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from gcs.link.telemetry import CommandAck
from mavlink_dialect import mavlink
from missiontime import Clock, seconds_to_us

Send = Callable[[Any], None]  # encode a message as the GCS and send it to the vehicles

BACKOFF = 1.5  # each retransmission waits this much longer than the attempt before
POLL_S = 0.02  # how often a wait looks again (mission time)
IN_PROGRESS_MAX_S = 120.0  # a command "in progress" longer than this has failed
AUTOPILOT = mavlink.MAV_COMP_ID_AUTOPILOT1


def _enum_name(enum: str, value: int, prefix: str = "") -> str:
    entry = mavlink.enums[enum].get(value)
    return entry.name.removeprefix(prefix) if entry is not None else str(value)


class CommandError(Exception):
    """A command the vehicle refused or never acknowledged; `result` is the MAV_RESULT (None: no ACK)."""

    def __init__(self, system_id: int, command: int, result: int | None, detail: str = "") -> None:
        self.system_id, self.command, self.result = system_id, command, result
        what = "no COMMAND_ACK" if result is None else _enum_name("MAV_RESULT", result)
        name = _enum_name("MAV_CMD", command)
        super().__init__(f"aPad {system_id}: {name} failed: {what}{f' ({detail})' if detail else ''}")


@dataclass
class _Pending:
    system_id: int
    command: int
    ack: CommandAck | None = None


class CommandClient:
    def __init__(self, send: Send, clock: Clock) -> None:
        self._send = send
        self._clock = clock
        self._pending: list[_Pending] = []

    def on_ack(self, system_id: int, ack: CommandAck) -> None:
        """The router hands every validated COMMAND_ACK here."""
        for pending in self._pending:
            if pending.system_id == system_id and pending.command == ack.command:
                pending.ack = ack

    def send_long(
        self, system_id: int, command: int, params: tuple[float, ...] = (), timeout_s: float = 1.0, retries: int = 3,
        component_id: int = AUTOPILOT, clock: Clock | None = None,
    ) -> CommandAck:
        """COMMAND_LONG until ACCEPTED (returns the ACK) or refused / never acknowledged (`CommandError`).

        `clock`: the clock the caller waits on (its own `ProcessClock` when several aPads' loops
        share the link); default the link's."""
        p = (tuple(float(x) for x in params) + (0.0,) * 7)[:7]

        def build(confirmation: int) -> Any:
            return mavlink.MAVLink_command_long_message(system_id, component_id, command, confirmation, *p)

        return self._run(system_id, command, build, timeout_s, retries, clock or self._clock)

    def send_int(
        self, system_id: int, command: int, frame: int, params: tuple[float, float, float, float], x: int, y: int,
        z: float = 0.0, timeout_s: float = 1.0, retries: int = 3, component_id: int = AUTOPILOT,
        clock: Clock | None = None,
    ) -> CommandAck:
        """COMMAND_INT (positions as degE7 integers); same protocol as `send_long`."""

        def build(confirmation: int) -> Any:
            # COMMAND_INT has no confirmation field: a retransmission is byte-identical but for its seq.
            return mavlink.MAVLink_command_int_message(system_id, component_id, frame, command, 0, 0, *params, x, y, z)

        return self._run(system_id, command, build, timeout_s, retries, clock or self._clock)

    def _run(
        self, system_id: int, command: int, build: Callable[[int], Any], timeout_s: float, retries: int, clock: Clock
    ) -> CommandAck:
        pending = _Pending(system_id, command)
        self._pending.append(pending)
        try:
            wait_s = timeout_s
            give_up_us = clock.now_us + seconds_to_us(IN_PROGRESS_MAX_S)
            for attempt in range(retries + 1):
                pending.ack = None
                self._send(build(attempt))
                deadline = clock.now_us + seconds_to_us(wait_s)
                clock.sleep(0)
                while True:
                    ack = pending.ack
                    if ack is not None and ack.result == mavlink.MAV_RESULT_IN_PROGRESS:
                        if clock.now_us >= give_up_us:
                            raise CommandError(system_id, command, ack.result, f"over {IN_PROGRESS_MAX_S:g} s")
                        pending.ack = None  # keep waiting for the final result
                        deadline = clock.now_us + seconds_to_us(wait_s)
                    elif ack is not None:
                        if ack.result != mavlink.MAV_RESULT_ACCEPTED:
                            detail = f"reason {ack.result_param2}" if ack.result_param2 else ""
                            raise CommandError(system_id, command, ack.result, detail)
                        return ack
                    if clock.now_us >= deadline:
                        break
                    clock.sleep(min(POLL_S, wait_s))
                wait_s *= BACKOFF
            raise CommandError(system_id, command, None, f"{retries + 1} attempts, {timeout_s:g} s and up")
        finally:
            self._pending.remove(pending)
