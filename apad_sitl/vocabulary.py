"""The aPad's own words: its mission primitives, their progress, and its docking latches.

Shared by the SITL vehicle and every GCS that commands an aPad. The dialect's APAD_PRIMITIVE,
PRIMITIVE_PROGRESS and DOCK_LATCH_STATE carry the same values on the wire (a test holds them
together). Custom modes are ArduRover's, so stock MAVLink tools name them right.
"""

from __future__ import annotations

from enum import IntEnum

N_SLOTS = 4  # docking/charging slots, numbered 1..N_SLOTS


class Primitive(IntEnum):
    IDLE = 0
    GOTO = 1
    HOLD = 2
    DOCK = 3
    UNDOCK = 4


class Progress(IntEnum):
    NONE = 0
    IN_PROGRESS = 1  # the paper's Listing 1: `while goto_status(...) == 1`
    DONE = 2
    FAILED = 3


class Latch(IntEnum):
    OPEN = 0
    CLOSING = 1
    LATCHED = 2
    RELEASING = 3


class RoverMode(IntEnum):
    """ArduRover custom modes the aPad uses (HEARTBEAT.custom_mode)."""

    HOLD = 4
    GUIDED = 15
