"""The aMussel's own words: its states and the commands it obeys.

The model owns these; the dialect's AMUSSEL_STATE and AMUSSEL_COMMAND_TYPE carry the same values
on the wire (a test holds the two together), so a received value is checked once, at the edge,
and then is one of these.
"""

from __future__ import annotations

from enum import IntEnum


class MusselState(IntEnum):
    ACTIVE = 0  # submerged, measuring
    SURFACING = 1  # called up, rising
    FLOATING = 2  # at the surface, waiting to be docked
    DOCKED = 3  # latched in an aPad slot, charging, not measuring
    SINKING = 4  # released, going back down
    DEPLETED = 5  # battery empty: inactive wherever it is


class MusselCommand(IntEnum):
    SURFACE = 1
    SINK = 2
