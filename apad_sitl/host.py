"""What a part of the SITL aPad is built with: the narrow host it talks through, and the words of commands.

A part (streams, modes, navigation, docking, param_server, mission_protocol, and the command table
itself) never sees the `SitlVehicle`: it gets a `PartHost` (receive, send, log, count, the time), the
`ApadState` it reads and changes (`apad_sitl.state`), a `CommandRegistry` if it answers commands, and
whatever plain values it needs (the local frame, the geofence). `SitlVehicle` is the host of the real
vehicle; a test may build any part with a small host of its own.

A command handler takes a `Command` and answers a `Reply`; it validates its own parameters (`whole`,
`finite`) and never raises on a bad value. A value that is no legal value of its field (NaN,
infinite, not a whole number, out of range, an unknown enum) answers `invalid(field)`: DENIED on
the wire and one count under "invalid:COMMAND_LONG:param2".
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

from mavlink_dialect import mavlink

MessageHandler = Callable[[Any], None]  # a decoded pymavlink message in


def invalid_reason(message: str, field: str) -> str:
    """The drop counter's key for a received `message` whose `field` holds no legal value."""
    return f"invalid:{message}:{field}"


def unsupported_reason(message: str) -> str:
    """The drop counter's key for a received `message` asking for what the aPad does not do."""
    return f"unsupported:{message}"


class PartHost(Protocol):
    """The few things the parts share, and all they may use of the vehicle that hosts them."""

    # Mission time of the latest task; messages handled between tasks are dated by it. A part's
    # own scheduled task sets it when it fires.
    now_us: int

    @property
    def closed(self) -> bool:
        """Whether the vehicle has closed (nothing more is sent, no task rescheduled)."""
        ...

    def on(self, msg_id: int, handler: MessageHandler) -> None:
        """Route every received message `msg_id` to `handler` (one handler per message id)."""
        ...

    def send(self, msg: mavlink.MAVLink_message) -> None: ...

    def for_us(self, target_system: int, target_component: int) -> bool:
        """Whether a message with these targets is addressed to this vehicle (0 is everyone)."""
        ...

    def count_invalid(self, message: str, field: str) -> None:
        """Count a received `message` dropped (or refused) because `field` holds no legal value."""
        ...

    def count_unsupported(self, message: str) -> None:
        """Count a received `message` that asks for something this vehicle does not do."""
        ...

    def event(self, event: str, /, **fields: Any) -> None:
        """Log an event (JSON-lines), stamped with `now_us`."""
        ...

    def statustext(self, severity: int, text: str) -> None:
        """Send a STATUSTEXT."""
        ...


# ---------------------------------------------------------------------- commands

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
    invalid: str | None = None  # the field that failed validation: counted by the host
    then: Callable[[], None] | None = None  # run after the ACK when accepted (a requested message)


ACCEPT = Reply(ACCEPTED)
DENY = Reply(DENIED)

CommandHandler = Callable[[Command], Reply]


class CommandRegistry(Protocol):
    """Where a part registers the MAV_CMDs it answers (`apad_sitl.command_handler.CommandTable`)."""

    def register(self, command: int, handler: CommandHandler, *, stateful: bool = False) -> None:
        """Route `command` to `handler`. `stateful`: a retransmission of it is re-ACKed, not re-run."""
        ...


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
