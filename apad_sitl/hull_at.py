"""The hull of a closed form at its step count, made once per count: the streams, the failsafe and the
energy meter read it many times an instant, and a closed form's `after(n)` is a few float operations
each time (`rest`, `cruise`, `settling`)."""

from __future__ import annotations

from collections.abc import Callable

from apad_sitl.vehicle import VehicleState


class HullAt:
    """The last hull made, and the step count it was made for (0: the closed form's origin)."""

    __slots__ = ("_state", "_steps")

    def __init__(self, origin: VehicleState) -> None:
        self._steps, self._state = 0, origin

    def at(self, steps: int, make: Callable[[int], VehicleState]) -> VehicleState:
        """The hull after `steps` steps: `make(steps)`, or the one made for that count already."""
        if steps != self._steps:
            self._steps, self._state = steps, make(steps)
        return self._state
