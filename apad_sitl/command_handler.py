"""The MAVLink command protocol of the aPad: COMMAND_LONG or COMMAND_INT in, one COMMAND_ACK out.

`CommandTable` turns both messages into one `Command`, spots retransmissions and hands the command
to the handler a part registered for its MAV_CMD (`apad_sitl.host`: `Command`, `Reply`, the
validation helpers). A handler's `invalid(field)` is counted by the host as a drop under
"invalid:COMMAND_LONG:param2"; a MAV_CMD nobody registered is answered UNSUPPORTED.

Retransmissions (a repeat must not step the model twice): a command that changes the vehicle's
state, identical in content to the last one accepted from the same source while what it started is
still what the vehicle does (the same mode, primitive, target, slot, aMussel and speed: the
command's `Effect`), is a re-send after a lost ACK or a duplicated datagram. It is answered with
the first answer and not executed again. No time window: a re-send that comes after the failsafe
(or anything else) changed the vehicle's course is a command to do it again, and it is executed.
A datagram the network duplicated is the very same frame, sequence number included: one seen in
the last DUPLICATE_HORIZON_US (far less than the 8-bit sequence takes to wrap) is answered, never
executed, whatever happened in between.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from dataclasses import dataclass
from typing import Any

from apad_sitl import messages as msgs
from apad_sitl.host import ACCEPTED, UNSUPPORTED, Command, CommandHandler, PartHost, Reply
from apad_sitl.state import ApadState
from apad_sitl.vocabulary import Progress
from mavlink_dialect import mavlink

DUPLICATE_HORIZON_US = 30 * 1_000_000  # a GCS at 2 Hz heartbeats wraps its 8-bit sequence in > 2 min
RECENT_FRAMES = 64


@dataclass(frozen=True)
class _Entry:
    handler: CommandHandler
    stateful: bool  # changes the vehicle's state: takes part in retransmission detection


@dataclass(frozen=True)
class Effect:
    """What a stateful command leaves the vehicle doing. Progress and latches may move on under it
    (IN_PROGRESS to DONE changes nothing a re-send would), but a failed primitive is no longer in force."""

    mode: int
    armed: bool
    primitive: tuple[Any, ...]  # kind, slot, aMussel, target, speed and radius of the primitive
    failed: bool

    @classmethod
    def of(cls, apad: ApadState) -> Effect:
        p = apad.primitive
        return cls(apad.mode, apad.armed,
                   (p.kind, p.slot, p.mussel_id, p.target_x_m, p.target_y_m, p.speed_mps, p.radius_m),
                   p.progress == Progress.FAILED)


@dataclass(frozen=True)
class _Executed:
    key: tuple[Any, ...]
    result: int
    result_param2: int
    effect: Effect


class CommandTable:
    """MAV_CMD -> handler. Parts `register` theirs; the table receives COMMAND_LONG and COMMAND_INT.

    It reads `apad` to tell a retransmission from a command to do it again (`Effect`)."""

    def __init__(self, host: PartHost, apad: ApadState) -> None:
        self._host = host
        self._apad = apad
        self._entries: dict[int, _Entry] = {}
        self._executed: dict[tuple[int, int], _Executed] = {}  # (system, component) -> last accepted
        # Frames of stateful commands executed lately: (system, component, seq, key) -> (answer, time)
        self._frames: OrderedDict[tuple[Any, ...], tuple[int, int, int]] = OrderedDict()
        host.on(mavlink.MAVLINK_MSG_ID_COMMAND_LONG, self._on_command_long)
        host.on(mavlink.MAVLINK_MSG_ID_COMMAND_INT, self._on_command_int)

    def register(self, command: int, handler: CommandHandler, *, stateful: bool = False) -> None:
        """Route `command` to `handler`. `stateful`: a retransmission of it is re-ACKed, not re-run."""
        if command in self._entries:
            raise ValueError(f"{_cmd_name(command)} already has a handler")
        self._entries[command] = _Entry(handler, stateful)

    def _on_command_long(self, msg: Any) -> None:
        if not self._host.for_us(msg.target_system, msg.target_component):
            return
        params = (msg.param1, msg.param2, msg.param3, msg.param4, msg.param5, msg.param6, msg.param7)
        self.handle(Command(msg.command, params, None, msg.get_srcSystem(), msg.get_srcComponent(), msg.get_seq()))

    def _on_command_int(self, msg: Any) -> None:
        if not self._host.for_us(msg.target_system, msg.target_component):
            return
        params = (msg.param1, msg.param2, msg.param3, msg.param4, float(msg.x), float(msg.y), msg.z)
        self.handle(Command(msg.command, params, msg.frame, msg.get_srcSystem(), msg.get_srcComponent(),
                            msg.get_seq()))

    def handle(self, cmd: Command) -> None:
        """Execute (or recognise as a retransmission) and ACK; a requested message follows the ACK."""
        host, apad = self._host, self._apad
        source = (cmd.source_system, cmd.source_component)
        entry = self._entries.get(cmd.command)
        stateful = entry is not None and entry.stateful
        last = self._executed.get(source) if stateful else None
        frame = self._frames.get((*source, cmd.seq, cmd.key)) if stateful and cmd.seq >= 0 else None
        if frame is not None and host.now_us - frame[2] <= DUPLICATE_HORIZON_US:
            reply = Reply(frame[0], frame[1])
            host.event("command_duplicate", command=cmd.command, result=_result_name(reply.result))
        elif last is not None and last.key == cmd.key and last.effect == Effect.of(apad):
            reply = Reply(last.result, last.result_param2)
            host.event("command_retry", command=cmd.command, result=_result_name(reply.result))
        else:
            if entry is None:
                reply = Reply(UNSUPPORTED)
                host.count_unsupported(cmd.message)
            else:
                reply = entry.handler(cmd)
            if stateful:
                if reply.result == ACCEPTED:
                    self._executed[source] = _Executed(cmd.key, reply.result, reply.param2, Effect.of(apad))
                else:
                    self._executed.pop(source, None)
                if cmd.seq >= 0:
                    self._frames[(*source, cmd.seq, cmd.key)] = (reply.result, reply.param2, host.now_us)
                    if len(self._frames) > RECENT_FRAMES:
                        self._frames.popitem(last=False)
            extra: dict[str, Any] = {}
            if reply.invalid is not None:
                host.count_invalid(cmd.message, reply.invalid)
                extra["invalid"] = reply.invalid
            host.event("command", command=cmd.command, name=_cmd_name(cmd.command),
                    params=[_json_float(p) for p in cmd.params], frame=cmd.frame,
                    source=list(source), result=_result_name(reply.result), result_param2=reply.param2, **extra)
        host.send(msgs.command_ack(cmd.command, reply.result, reply.param2, cmd.source_system, cmd.source_component))
        # Answers to requests go after the ACK, as ArduPilot does.
        if reply.result == ACCEPTED and reply.then is not None:
            reply.then()


def _json_float(value: float) -> float | None:
    return value if math.isfinite(value) else None


def _cmd_name(command: int) -> str:
    entry = mavlink.enums["MAV_CMD"].get(command)
    return entry.name if entry is not None else str(command)


def _result_name(result: int) -> str:
    entry = mavlink.enums["MAV_RESULT"].get(result)
    return entry.name.removeprefix("MAV_RESULT_") if entry is not None else str(result)
