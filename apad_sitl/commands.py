"""The MAVLink command protocol of the aPad: COMMAND_LONG or COMMAND_INT in, one COMMAND_ACK out.

`CommandTable` turns both messages into one `Command`, spots retransmissions and hands the command
to the handler a part registered for its MAV_CMD. A handler validates its own parameters (`whole`,
`finite`) and answers a `Reply`; it never raises on a bad value. A value that is no legal value of
its field (NaN, infinite, not a whole number, out of range, an unknown enum) answers `invalid(field)`:
DENIED on the wire and one count in `vehicle.dropped` under "invalid:COMMAND_LONG:param2".

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
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from apad_sitl import messages as msgs
from apad_sitl.vocabulary import Progress
from mavlink_dialect import mavlink

if TYPE_CHECKING:
    from apad_sitl.endpoint import SitlVehicle

DUPLICATE_HORIZON_US = 30 * 1_000_000  # a GCS at 2 Hz heartbeats wraps its 8-bit sequence in > 2 min
RECENT_FRAMES = 64

ACCEPTED = mavlink.MAV_RESULT_ACCEPTED
DENIED = mavlink.MAV_RESULT_DENIED
UNSUPPORTED = mavlink.MAV_RESULT_UNSUPPORTED


@dataclass(frozen=True)
class Command:
    """A COMMAND_LONG or COMMAND_INT addressed to us, normalised."""

    command: int  # MAV_CMD
    params: tuple[float, ...]  # param1..param7; for COMMAND_INT param5/6 are x/y (degE7) and param7 z
    frame: int | None  # COMMAND_INT frame; None for COMMAND_LONG (whose lat/lon are degrees)
    source_system: int
    source_component: int
    seq: int = -1  # the frame's MAVLink sequence number (-1: not from a frame)

    @property
    def message(self) -> str:
        """The message it came in: "COMMAND_LONG" or "COMMAND_INT"."""
        return "COMMAND_LONG" if self.frame is None else "COMMAND_INT"

    def field(self, n: int) -> str:
        """The wire name of parameter `n` (1..7): COMMAND_INT calls 5, 6, 7 x, y, z."""
        if self.frame is not None and n >= 5:
            return "xyz"[n - 5]
        return f"param{n}"

    @property
    def key(self) -> tuple[Any, ...]:
        """What makes a retransmission: the same command with the same parameters (NaN == NaN)."""
        return (self.command, self.frame, tuple(p if p == p else None for p in self.params))

    def lat_lon_deg(self) -> tuple[float, float]:
        lat, lon = self.params[4], self.params[5]
        return (lat / 1e7, lon / 1e7) if self.frame is not None else (lat, lon)


@dataclass(frozen=True)
class Reply:
    """A handler's answer: what the COMMAND_ACK says, and what was wrong with the command if anything."""

    result: int  # MAV_RESULT
    param2: int = 0  # COMMAND_ACK.result_param2 (why a Dock/Undock was refused)
    invalid: str | None = None  # the field that failed validation: counted in `vehicle.dropped`
    then: Callable[[], None] | None = None  # run after the ACK when accepted (a requested message)


ACCEPT = Reply(ACCEPTED)
DENY = Reply(DENIED)

CommandHandler = Callable[[Command], Reply]


def invalid(field: str, param2: int = 0) -> Reply:
    """DENIED because `field` holds no legal value; the table counts it as a drop."""
    return Reply(DENIED, param2, invalid=field)


def whole(value: float, lo: int, hi: int) -> int | None:
    """`value` as an int if it is a whole number in [lo, hi], else None. int() never sees NaN or inf."""
    if not (math.isfinite(value) and lo <= value <= hi and value == math.floor(value)):
        return None
    return int(value)


def finite(value: float, lo: float = -math.inf, hi: float = math.inf) -> float | None:
    """`value` if it is a finite number in [lo, hi], else None."""
    return value if math.isfinite(value) and lo <= value <= hi else None


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
    def of(cls, vehicle: SitlVehicle) -> Effect:
        p = vehicle.primitive
        return cls(vehicle.mode, vehicle.armed,
                   (p.kind, p.slot, p.mussel_id, p.target_x_m, p.target_y_m, p.speed_mps, p.radius_m),
                   p.progress == Progress.FAILED)


@dataclass(frozen=True)
class _Executed:
    key: tuple[Any, ...]
    result: int
    result_param2: int
    effect: Effect


class CommandTable:
    """MAV_CMD -> handler. Parts `register` theirs; the table receives COMMAND_LONG and COMMAND_INT."""

    def __init__(self, vehicle: SitlVehicle) -> None:
        self._v = vehicle
        self._entries: dict[int, _Entry] = {}
        self._executed: dict[tuple[int, int], _Executed] = {}  # (system, component) -> last accepted
        # Frames of stateful commands executed lately: (system, component, seq, key) -> (answer, time)
        self._frames: OrderedDict[tuple[Any, ...], tuple[int, int, int]] = OrderedDict()
        vehicle.on(mavlink.MAVLINK_MSG_ID_COMMAND_LONG, self._on_command_long)
        vehicle.on(mavlink.MAVLINK_MSG_ID_COMMAND_INT, self._on_command_int)

    def register(self, command: int, handler: CommandHandler, *, stateful: bool = False) -> None:
        """Route `command` to `handler`. `stateful`: a retransmission of it is re-ACKed, not re-run."""
        if command in self._entries:
            raise ValueError(f"{_cmd_name(command)} already has a handler")
        self._entries[command] = _Entry(handler, stateful)

    def _on_command_long(self, msg: Any) -> None:
        if not self._v.for_us(msg.target_system, msg.target_component):
            return
        params = (msg.param1, msg.param2, msg.param3, msg.param4, msg.param5, msg.param6, msg.param7)
        self.handle(Command(msg.command, params, None, msg.get_srcSystem(), msg.get_srcComponent(), msg.get_seq()))

    def _on_command_int(self, msg: Any) -> None:
        if not self._v.for_us(msg.target_system, msg.target_component):
            return
        params = (msg.param1, msg.param2, msg.param3, msg.param4, float(msg.x), float(msg.y), msg.z)
        self.handle(Command(msg.command, params, msg.frame, msg.get_srcSystem(), msg.get_srcComponent(),
                            msg.get_seq()))

    def handle(self, cmd: Command) -> None:
        """Execute (or recognise as a retransmission) and ACK; a requested message follows the ACK."""
        v = self._v
        source = (cmd.source_system, cmd.source_component)
        entry = self._entries.get(cmd.command)
        stateful = entry is not None and entry.stateful
        last = self._executed.get(source) if stateful else None
        frame = self._frames.get((*source, cmd.seq, cmd.key)) if stateful and cmd.seq >= 0 else None
        if frame is not None and v.now_us - frame[2] <= DUPLICATE_HORIZON_US:
            reply = Reply(frame[0], frame[1])
            v.event("command_duplicate", command=cmd.command, result=_result_name(reply.result))
        elif last is not None and last.key == cmd.key and last.effect == Effect.of(v):
            reply = Reply(last.result, last.result_param2)
            v.event("command_retry", command=cmd.command, result=_result_name(reply.result))
        else:
            if entry is None:
                reply = Reply(UNSUPPORTED)
                v.dropped[f"unsupported:{cmd.message}"] += 1
            else:
                reply = entry.handler(cmd)
            if stateful:
                if reply.result == ACCEPTED:
                    self._executed[source] = _Executed(cmd.key, reply.result, reply.param2, Effect.of(v))
                else:
                    self._executed.pop(source, None)
                if cmd.seq >= 0:
                    self._frames[(*source, cmd.seq, cmd.key)] = (reply.result, reply.param2, v.now_us)
                    if len(self._frames) > RECENT_FRAMES:
                        self._frames.popitem(last=False)
            extra: dict[str, Any] = {}
            if reply.invalid is not None:
                v.count_invalid(cmd.message, reply.invalid)
                extra["invalid"] = reply.invalid
            v.event("command", command=cmd.command, name=_cmd_name(cmd.command),
                    params=[_json_float(p) for p in cmd.params], frame=cmd.frame,
                    source=list(source), result=_result_name(reply.result), result_param2=reply.param2, **extra)
        v.send(msgs.command_ack(cmd.command, reply.result, reply.param2, cmd.source_system, cmd.source_component))
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
