"""The aPad's state that its parts share: the hull, the primitive and slots, mode, arming, speed
override and parameters. What a checkpoint saves, and what every part reads.

Three changes are reported: `set_primitive`, `set_mode` and `set_armed` call the listeners the
vehicle's core registered for them, in the order registered (the "primitive" event, the slot
bookkeeping, the on-change telemetry: their order is what the .tlogs and event logs record). A
part that changes the mode or the primitive calls these and knows nothing of who listens.
Assigning a field changes it silently: the physics steps `state` (or lets it rest, `rest`), PARAM_SET swaps `params`,
DO_CHANGE_SPEED sets `speed_override_mps`, the energy part counts in `energy`, and a checkpoint's
restore puts mode and arming back.
"""

from __future__ import annotations

from collections.abc import Callable

from apad_sitl.energy_counters import EnergyCounters
from apad_sitl.params import ApadParams
from apad_sitl.primitives import PrimitiveState
from apad_sitl.rest import ChargingRest, Rest
from apad_sitl.vehicle import VehicleState
from apad_sitl.vocabulary import RoverMode

PrimitiveListener = Callable[[PrimitiveState, PrimitiveState], None]  # (old, new)
ModeListener = Callable[[int], None]  # the new mode
ArmedListener = Callable[[bool], None]  # armed now


class ApadState:
    """The aPad's mutable state, reporting the changes of its primitive, mode and arming."""

    def __init__(self, params: ApadParams) -> None:
        self.params = params  # frozen; PARAM_SET swaps in a new set
        self._state = VehicleState()  # the hull: position, velocity, heading, battery
        # Not None: the hull rests at a fixed point and `state` is advanced in closed form (apad_sitl.rest).
        self.rest: Rest | ChargingRest | None = None
        # Set while the physics task is parked at rest (`apad_sitl.parking`): takes the steps it skipped.
        self.pending: Callable[[], None] | None = None
        self.mode: int = RoverMode.HOLD
        self.armed = True  # boots armed so a mission script needs no arming step
        self.speed_override_mps = 0.0  # DO_CHANGE_SPEED for later Go Tos; 0: SPEED_MAX
        self.energy = EnergyCounters()  # energy passed to aMussels and taken at home (apad_sitl.energy)
        self._primitive = PrimitiveState()
        self._primitive_listeners: list[PrimitiveListener] = []
        self._mode_listeners: list[ModeListener] = []
        self._armed_listeners: list[ArmedListener] = []

    @property
    def state(self) -> VehicleState:
        """The hull now; while it rests, the rest's closed form after the steps counted so far (the
        steps a parked physics task skipped taken first)."""
        if self.pending is not None:
            self.pending()
        rest = self.rest
        return self._state if rest is None else rest.state()

    @state.setter
    def state(self, value: VehicleState) -> None:
        """A new hull state (a physics step, a battery draw, a restore) ends any rest."""
        self.settle()  # the steps skipped so far were taken from the old state
        self.rest = None
        self._state = value

    def settle(self) -> None:
        """Take the steps a parked physics task skipped (the energy counters are read after this)."""
        if self.pending is not None:
            self.pending()

    @property
    def primitive(self) -> PrimitiveState:
        """The running primitive and the four slots; changed by `set_primitive` only."""
        return self._primitive

    def on_primitive(self, listener: PrimitiveListener) -> None:
        """Call `listener(old, new)` whenever `set_primitive` swaps in a new primitive state."""
        self._primitive_listeners.append(listener)

    def on_mode(self, listener: ModeListener) -> None:
        """Call `listener(mode)` whenever `set_mode` changes the mode."""
        self._mode_listeners.append(listener)

    def on_armed(self, listener: ArmedListener) -> None:
        """Call `listener(armed)` whenever `set_armed` changes the arming."""
        self._armed_listeners.append(listener)

    def set_primitive(self, new: PrimitiveState) -> None:
        """Swap in a new primitive state and report it (unless it is the very same object)."""
        old, self._primitive = self._primitive, new
        if new is old:
            return
        for listener in self._primitive_listeners:
            listener(old, new)

    def set_mode(self, mode: int) -> None:
        if mode != self.mode:
            self.mode = mode
            for listener in self._mode_listeners:
                listener(mode)

    def set_armed(self, armed: bool) -> None:
        if armed != self.armed:
            self.armed = armed
            for listener in self._armed_listeners:
                listener(armed)
