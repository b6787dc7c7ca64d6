"""What the aPad's battery gave and took (`apad_sitl.energy` counts it; a checkpoint keeps it)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class EnergyCounters:
    """Wh since the mission began, and whether the aPad charges at home now."""

    passed_wh: float = 0.0  # into aMussel batteries
    drawn_wh: float = 0.0  # from the aPad's battery for them (passed / efficiency)
    home_wh: float = 0.0  # into the aPad's battery at home
    home_charges: int = 0  # times it began charging at home
    charging: bool = False  # at home and charging now
