"""The MAVLink command protocol, GCS side: send, wait for the COMMAND_ACK, retry with backoff.

Waits run on the clock (`clock.sleep`), so the same client serves lockstep runs and the field.
Every wait is bounded: `retries + 1` attempts, the first waiting `timeout_s` and each next one
`BACKOFF` times the one before (1 + 1.5 + 2.25 + 3.375 s by default); at the bound a
`CommandError` with `result=None`. A vehicle that answers IN_PROGRESS gets at most
`IN_PROGRESS_MAX_S` in all before the command fails with that result. A `give_up` hook, asked at
each look of a wait, may end it at once (the console quitting while the aPad is silent: it answers
nothing, so its retries are not waited out).

`refusal_words` is the one place a MAV_RESULT, and our dialect's refusal reason for Dock and Undock
(COMMAND_ACK.result_param2, `apad_sitl.primitives.Refusal`), become the words an operator reads
("slot 2 occupied"); `CommandError.words` carries them.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from apad_sitl.primitives import Refusal
from gcs.link.telemetry import CommandAck
from mavlink_dialect import MAV_CMD_APAD_DOCK, MAV_CMD_APAD_UNDOCK, mavlink
from missiontime import Clock, seconds_to_us

Send = Callable[[Any], None]  # encode a message as the GCS and send it to the vehicles
# Asked at each look of an ACK wait with the aPad's system id and the command: words (why) end the
# wait at once, no more sends, with a `CommandError` (result None) carrying them; None waits on.
GiveUp = Callable[[int, int], str | None]

BACKOFF = 1.5  # each retransmission waits this much longer than the attempt before
POLL_S = 0.02  # how often a wait looks again (mission time)
IN_PROGRESS_MAX_S = 120.0  # a command "in progress" longer than this has failed
AUTOPILOT = mavlink.MAV_COMP_ID_AUTOPILOT1


def _enum_name(enum: str, value: int, prefix: str = "") -> str:
    entry = mavlink.enums[enum].get(value)
    return entry.name.removeprefix(prefix) if entry is not None else str(value)


# What each MAV_RESULT means to the operator, when the command's own reason says no more.
RESULT_WORDS: dict[int, str] = {
    mavlink.MAV_RESULT_TEMPORARILY_REJECTED: "busy, try again",
    mavlink.MAV_RESULT_DENIED: "refused by the aPad",
    mavlink.MAV_RESULT_UNSUPPORTED: "not supported by the aPad",
    mavlink.MAV_RESULT_FAILED: "failed on the aPad",
    mavlink.MAV_RESULT_IN_PROGRESS: "still in progress at the time limit",
    mavlink.MAV_RESULT_COMMAND_LONG_ONLY: "the aPad takes it only as COMMAND_LONG",
    mavlink.MAV_RESULT_COMMAND_INT_ONLY: "the aPad takes it only as COMMAND_INT",
}
# Why a Dock or Undock was refused (the aPad's reason in result_param2), with its slot and aMussel.
REFUSAL_WORDS: dict[Refusal, str] = {
    Refusal.BAD_SLOT: "no slot {slot} (slots are 1..4)",
    Refusal.BAD_MUSSEL_ID: "{mussel} is no aMussel id",
    Refusal.UNKNOWN_MUSSEL: "the aPad has not heard aMussel {mussel}",
    Refusal.OUT_OF_REACH: "aMussel {mussel} out of docking reach",
    Refusal.SLOT_OCCUPIED: "slot {slot} occupied",
    Refusal.ALREADY_DOCKED: "aMussel {mussel} already docked",
    Refusal.SLOT_EMPTY: "slot {slot} empty",
    Refusal.WRONG_MUSSEL: "another aMussel in slot {slot}",
    Refusal.SLOT_BUSY: "slot {slot} busy releasing",
}
COMMAND_WORDS: dict[int, str] = {
    MAV_CMD_APAD_DOCK: "dock",
    MAV_CMD_APAD_UNDOCK: "undock",
    mavlink.MAV_CMD_DO_REPOSITION: "go to",
    mavlink.MAV_CMD_DO_SET_MODE: "mode change",
    mavlink.MAV_CMD_SET_MESSAGE_INTERVAL: "telemetry rate",
    mavlink.MAV_CMD_REQUEST_MESSAGE: "status request",
}
_REFUSALS = frozenset(int(r) for r in Refusal)


def refusal_words(command: int, result: int | None, reason: int = 0, params: tuple[float, ...] = ()) -> str:
    """Why `command` (sent with `params`) did not happen, in words: "slot 2 occupied"."""
    if result is None:
        return "no answer from the aPad"
    if command in (MAV_CMD_APAD_DOCK, MAV_CMD_APAD_UNDOCK) and reason in _REFUSALS:
        slot, mussel = (_shown(params[i]) if len(params) > i else "?" for i in (0, 1))
        return REFUSAL_WORDS[Refusal(reason)].format(slot=slot, mussel=mussel)
    return RESULT_WORDS.get(result, f"result {result}")


def command_words(command: int) -> str:
    """The command as the operator calls it ("dock"); its MAVLink name if it has no other."""
    return COMMAND_WORDS.get(command) or _enum_name("MAV_CMD", command, "MAV_CMD_").lower()


def _shown(value: float) -> str:
    return str(int(value)) if value == value and abs(value) < 2**31 and value == int(value) else repr(value)


class CommandError(Exception):
    """A command the vehicle refused or never acknowledged; `result` is the MAV_RESULT (None: no ACK),
    `reason` the dialect's refusal reason (result_param2), `words` why, as the operator reads it."""

    def __init__(self, system_id: int, command: int, result: int | None, detail: str = "", *, reason: int = 0,
                 params: tuple[float, ...] = (), words: str | None = None) -> None:
        self.system_id, self.command, self.result, self.reason = system_id, command, result, reason
        self.words = words or refusal_words(command, result, reason, params)
        what = "no COMMAND_ACK" if result is None else _enum_name("MAV_RESULT", result)
        raw = ", ".join(x for x in (what, f"reason {reason}" if reason else "", detail) if x)
        super().__init__(f"aPad {system_id}: {command_words(command)} failed: {self.words} ({raw})")


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
        self.give_up: GiveUp | None = None  # set by whoever must not wait on (`gcs.console.operator`)

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

        return self._run(system_id, command, build, timeout_s, retries, clock or self._clock, p)

    def send_int(
        self, system_id: int, command: int, frame: int, params: tuple[float, float, float, float], x: int, y: int,
        z: float = 0.0, timeout_s: float = 1.0, retries: int = 3, component_id: int = AUTOPILOT,
        clock: Clock | None = None,
    ) -> CommandAck:
        """COMMAND_INT (positions as degE7 integers); same protocol as `send_long`."""

        def build(confirmation: int) -> Any:
            # COMMAND_INT has no confirmation field: a retransmission is byte-identical but for its seq.
            return mavlink.MAVLink_command_int_message(system_id, component_id, frame, command, 0, 0, *params, x, y, z)

        return self._run(system_id, command, build, timeout_s, retries, clock or self._clock, params)

    def _run(
        self, system_id: int, command: int, build: Callable[[int], Any], timeout_s: float, retries: int, clock: Clock,
        params: tuple[float, ...],
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
                            raise CommandError(system_id, command, ack.result, f"over {IN_PROGRESS_MAX_S:g} s",
                                               params=params)
                        pending.ack = None  # keep waiting for the final result
                        deadline = clock.now_us + seconds_to_us(wait_s)
                    elif ack is not None:
                        if ack.result != mavlink.MAV_RESULT_ACCEPTED:
                            raise CommandError(system_id, command, ack.result, reason=ack.result_param2,
                                               params=params)
                        return ack
                    if clock.now_us >= deadline:
                        break
                    why = self.give_up(system_id, command) if self.give_up is not None else None
                    if why is not None:
                        raise CommandError(system_id, command, None, "given up", params=params, words=why)
                    clock.sleep(min(POLL_S, wait_s))
                wait_s *= BACKOFF
            raise CommandError(system_id, command, None, f"{retries + 1} attempts, {timeout_s:g} s and up",
                               params=params)
        finally:
            self._pending.remove(pending)
