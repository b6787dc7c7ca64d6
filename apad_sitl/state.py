"""The aPad's state that its parts share: the hull, the primitive and slots, mode, arming, speed
override, parameters, the water current and the energy counters. What a checkpoint saves, and what every
part reads.

Three changes are reported: `set_primitive`, `set_mode` and `set_armed` call the listeners the
vehicle's core registered for them, in the order registered (the "primitive" event, the slot
bookkeeping, the on-change telemetry: their order is what the .tlogs and event logs record). They
are the only way to change these three: `mode` and `armed` are read-only, so no part can change
them without its telemetry. A part that changes them calls these and knows nothing of who listens.
`restore` alone puts a checkpoint's mode and arming back silently: a restore is not a change the aPad made.

The parked physics (`apad_sitl.parking`) is settled here, not by the callers: every read of what
its skipped ticks change (the hull `state`, the `energy` counters) and every write of what they
step on (`state`, `params`, `current_mps`, the primitive, mode, arming) first takes the ticks skipped so far.
On the ideal link (`apad_sitl.streams`) a write of what the rest holds for also calls
`changed_while_parked` after it, so the physics (and the streams parked with it) tick again at once
when it ends the rest, not at the next message or read.
The physics itself steps `state` (or lets it rest, `rest`), PARAM_SET swaps `params`, DO_CHANGE_SPEED
sets `speed_override_mps` (read by the next Go To only, so plain), and the energy part counts in `energy`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, TypeAlias

from apad_sitl.energy_counters import EnergyCounters
from apad_sitl.params import ApadParams
from apad_sitl.primitives import PrimitiveState
from apad_sitl.rest import ChargingRest, Rest
from apad_sitl.vehicle import VehicleState
from apad_sitl.vocabulary import RoverMode

if TYPE_CHECKING:
    from apad_sitl.cruise import Cruise
    from apad_sitl.latch_hold import LatchHold
    from apad_sitl.settling import Settling
    from apad_sitl.track import Track

PrimitiveListener = Callable[[PrimitiveState, PrimitiveState], None]  # (old, new)
ModeListener = Callable[[int], None]  # the new mode
ArmedListener = Callable[[bool], None]  # armed now
# The hull advanced in closed form: at rest (`apad_sitl.rest`), or on the ideal link busy too (a Go To's
# cruise, `apad_sitl.cruise`; latch timers running while it holds still, `apad_sitl.latch_hold`; settling
# onto its hold point, `apad_sitl.settling`; stepped ahead where no equation holds, `apad_sitl.track`).
HullRest: TypeAlias = "Rest | ChargingRest | Cruise | LatchHold | Settling | Track"


class ApadState:
    """The aPad's mutable state, reporting the changes of its primitive, mode and arming."""

    def __init__(self, params: ApadParams, current_mps: tuple[float, float] = (0.0, 0.0)) -> None:
        self._params = params  # frozen; PARAM_SET swaps in a new set
        self._current_mps = current_mps
        self._state = VehicleState()  # the hull: position, velocity, heading, battery
        # Not None: the hull rests at a fixed point and `state` is advanced in closed form (apad_sitl.rest).
        self.rest: HullRest | None = None
        # Set while the physics task is parked at rest (`apad_sitl.parking`): takes the steps it skipped.
        self.pending: Callable[[], None] | None = None
        # Ideal-link mode (`apad_sitl.streams`): called after a setter changed the state while the physics
        # task is parked, which may end the rest with no message to settle it (the world, a test, a restore).
        self.changed_while_parked: Callable[[], None] | None = None
        self._mode: int = RoverMode.HOLD
        self._armed = True  # boots armed so a mission script needs no arming step
        self.speed_override_mps = 0.0  # DO_CHANGE_SPEED for later Go Tos; 0: SPEED_MAX
        self._energy = EnergyCounters()  # energy passed to aMussels and taken at home (apad_sitl.energy)
        self._primitive = PrimitiveState()
        self._primitive_listeners: list[PrimitiveListener] = []
        self._mode_listeners: list[ModeListener] = []
        self._armed_listeners: list[ArmedListener] = []

    def settle(self) -> None:
        """Take the steps a parked physics task skipped (no-op while it ticks). The accessors below call
        it; the vehicle's core calls it for what is not kept here (its time, the failsafe's flag)."""
        if self.pending is not None:
            self.pending()

    # ------------------------------------------------------------------ what the parked ticks change

    @property
    def state(self) -> VehicleState:
        """The hull now; while it rests, the rest's closed form after the steps counted so far (the
        steps a parked physics task skipped taken first)."""
        if self.pending is not None:  # settle() inline: every tick reads the hull
            self.pending()
        rest = self.rest
        return self._state if rest is None else rest.state()

    @state.setter
    def state(self, value: VehicleState) -> None:
        """A new hull state (a physics step, a battery draw, a restore) ends any rest."""
        self.settle()  # the steps skipped so far were taken from the old state
        self.rest = None
        self._state = value
        if self.pending is not None:
            self._changed()

    @property
    def energy(self) -> EnergyCounters:
        """Energy passed to aMussels and taken at home, counted in place (with the home charger's
        top-ups of the ticks a parked physics task skipped)."""
        if self.pending is not None:
            self.pending()
        return self._energy

    # ------------------------------------------------------------------ what the ticks step on

    @property
    def params(self) -> ApadParams:
        return self._params

    @params.setter
    def params(self, value: ApadParams) -> None:
        self.settle()  # the ticks until now ran with the old set
        self._params = value
        if self.pending is not None:
            self._changed()

    @property
    def current_mps(self) -> tuple[float, float]:
        """The water current (east, north) m/s the hull drifts in; scenarios may change it at run time."""
        return self._current_mps

    @current_mps.setter
    def current_mps(self, value: tuple[float, float]) -> None:
        self.settle()  # the ticks until now drifted in the old current
        self._current_mps = value
        if self.pending is not None:
            self._changed()

    @property
    def primitive(self) -> PrimitiveState:
        """The running primitive and the four slots; changed by `set_primitive` only (the latch timers a
        parked physics task skipped taken first: `apad_sitl.latch_hold`)."""
        if self.pending is not None:
            self.pending()
        return self._primitive

    @property
    def mode(self) -> int:
        """The rover mode (`RoverMode`); changed by `set_mode` only."""
        return self._mode

    @property
    def armed(self) -> bool:
        """Changed by `set_armed` only."""
        return self._armed

    # ------------------------------------------------------------------ reported changes

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
        self.settle()  # the ticks until now ran the old primitive
        old, self._primitive = self._primitive, new
        if new is old:
            return
        for listener in self._primitive_listeners:
            listener(old, new)
        if self.pending is not None:
            self._changed()

    def set_mode(self, mode: int) -> None:
        """Change the mode and report it (nothing if it is the mode already)."""
        if mode != self._mode:
            self.settle()
            self._mode = mode
            for listener in self._mode_listeners:
                listener(mode)

    def set_armed(self, armed: bool) -> None:
        """Arm or disarm and report it (nothing if it is so already)."""
        if armed != self._armed:
            self.settle()  # the ticks until now ran armed as before
            self._armed = armed
            for listener in self._armed_listeners:
                listener(armed)
            if self.pending is not None:
                self._changed()

    def _changed(self) -> None:
        if self.changed_while_parked is not None:
            self.changed_while_parked()

    # ------------------------------------------------------------------ a checkpoint's restore

    def restore(self, state: VehicleState, primitive: PrimitiveState, mode: int, armed: bool,
                speed_override_mps: float, energy: EnergyCounters) -> None:
        """Put back what a checkpoint saved (`gcs.mission.checkpoint.restore`). The hull, mode, arming,
        speed override and energy counters are set silently: the aPad did not change them, and the logs,
        cut back to the checkpoint, hold their events already. The primitive is swapped in by
        `set_primitive` and announced, as a restore always was (its "primitive" event, the slots'
        bookkeeping, PRIMITIVE_STATUS). `energy` is kept, not copied."""
        self.state = state  # settles: the steps skipped so far were taken from the old state
        self._mode, self._armed = mode, armed
        self.speed_override_mps = speed_override_mps
        self._energy = energy
        self.set_primitive(primitive)
