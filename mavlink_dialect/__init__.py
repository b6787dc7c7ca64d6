"""The subCULTron MAVLink dialect, its codec and the byte transports every MAVLink party uses.

`mavlink` is the module mavgen generated from `subcultron.xml` (common.xml included); the enums
below are the dialect's own, typed, so callers never reach into pymavlink's module globals.
"""

from __future__ import annotations

from enum import IntEnum

from mavlink_dialect import subcultron as mavlink
from mavlink_dialect.codec import Codec, CodecStats
from mavlink_dialect.transport import (
    AddressError,
    MemoryTransport,
    Transport,
    memory_pair,
    open_transport,
)


class MusselState(IntEnum):
    ACTIVE = mavlink.AMUSSEL_STATE_ACTIVE
    SURFACING = mavlink.AMUSSEL_STATE_SURFACING
    FLOATING = mavlink.AMUSSEL_STATE_FLOATING
    DOCKED = mavlink.AMUSSEL_STATE_DOCKED
    SINKING = mavlink.AMUSSEL_STATE_SINKING
    DEPLETED = mavlink.AMUSSEL_STATE_DEPLETED


class Latch(IntEnum):
    OPEN = mavlink.DOCK_LATCH_STATE_OPEN
    CLOSING = mavlink.DOCK_LATCH_STATE_CLOSING
    LATCHED = mavlink.DOCK_LATCH_STATE_LATCHED
    RELEASING = mavlink.DOCK_LATCH_STATE_RELEASING


class Primitive(IntEnum):
    IDLE = mavlink.APAD_PRIMITIVE_IDLE
    GOTO = mavlink.APAD_PRIMITIVE_GOTO
    HOLD = mavlink.APAD_PRIMITIVE_HOLD
    DOCK = mavlink.APAD_PRIMITIVE_DOCK
    UNDOCK = mavlink.APAD_PRIMITIVE_UNDOCK


class Progress(IntEnum):
    NONE = mavlink.PRIMITIVE_PROGRESS_NONE
    IN_PROGRESS = mavlink.PRIMITIVE_PROGRESS_IN_PROGRESS
    DONE = mavlink.PRIMITIVE_PROGRESS_DONE
    FAILED = mavlink.PRIMITIVE_PROGRESS_FAILED


class MusselCommand(IntEnum):
    SURFACE = mavlink.AMUSSEL_COMMAND_SURFACE
    SINK = mavlink.AMUSSEL_COMMAND_SINK


MAV_CMD_APAD_DOCK = mavlink.MAV_CMD_APAD_DOCK
MAV_CMD_APAD_UNDOCK = mavlink.MAV_CMD_APAD_UNDOCK

__all__ = [
    "MAV_CMD_APAD_DOCK",
    "MAV_CMD_APAD_UNDOCK",
    "AddressError",
    "Codec",
    "CodecStats",
    "Latch",
    "MemoryTransport",
    "MusselCommand",
    "MusselState",
    "Primitive",
    "Progress",
    "Transport",
    "mavlink",
    "memory_pair",
    "open_transport",
]
