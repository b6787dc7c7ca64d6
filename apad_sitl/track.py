"""A busy hull stepped ahead of time: the ideal link's closed form where no equation holds.

A Go To's turn and acceleration, its sqrt-law approach, the braking after its victory radius, a
Dock or an Undock moving the hull while a latch timer runs: there the hull obeys no closed form
(`cruise`, `settling`, `latch_hold` cover the stretches that do), and the physics task used to tick
every 0.1 s of them, an event each. `Track` runs the tick's own pure functions
(`primitives.velocity_setpoint`, `vehicle.step`, `primitives.step`) on the same floats, ahead of
time, in one call: step n of a track is the tick's step n to the bit, at a few microseconds a step
and no event. The physics task parks over it as over any bounded closed form (`parking`).

A track stops before the first step where a tick would do something a track cannot hold:

- the primitive changes other than its latch timers (a Go To reached, a latch closed or opened, a
  dock failed): that step is stepped, so its announcement goes out at its tick;
- the hull comes to rest (a fixed point: `rest.Rest` takes over at the tick that finds it);
- the home charger could act (near home and slow: the energy meter's step would charge);
- the battery runs flat (the thrusters stop: stepped, as the other closed forms leave it);
- `MAX_STEPS` steps (the next tick looks for a closed form again: a cruise, a settling, a track).

What it holds for is a rest's key (a command, a parameter, arming, the current end it) and, as a
latch hold, the fixes of the aMussels its closing latches check (`hull_step.rest_holds`).

Pure: no clock, no I/O. Only on the ideal link (`SitlVehicle(ideal_link=True)`): lockstep steps every tick.
"""

from __future__ import annotations

from collections.abc import Mapping

from apad_sitl import primitives as prim
from apad_sitl import vehicle as veh
from apad_sitl.energy_counters import EnergyCounters
from apad_sitl.home_charger import could_charge
from apad_sitl.latch_hold import timers_only
from apad_sitl.params import ApadParams
from apad_sitl.primitives import MusselFix, PrimitiveState
from apad_sitl.rest import at_rest
from apad_sitl.vehicle import BATTERY_EMPTY_V, VehicleState

MAX_STEPS = 64  # 6.4 s of physics at 10 Hz: what a command arriving early wastes at most
MIN_STEPS = 3  # shorter tracks are not worth parking the task for


class Track:
    """The hull and its primitive `steps` steps of `dt_s` on from `origin`, at most `limit`, as ticking makes them."""

    __slots__ = ("_primitives", "_states", "dt_s", "fixes", "key", "limit", "origin", "origin_primitive", "steps")

    def __init__(self, origin: VehicleState, origin_primitive: PrimitiveState, states: list[VehicleState],
                 primitives: list[PrimitiveState], dt_s: float, fixes: tuple[MusselFix | None, ...],
                 key: tuple[object, ...] = ()) -> None:
        self.origin, self.origin_primitive = origin, origin_primitive
        self._states, self._primitives = states, primitives
        self.dt_s = dt_s
        self.fixes = fixes  # the closing latches' aMussels as the track began: a status that moves one ends it
        self.key = key  # what it holds for (as a rest's key; the primitive's timers kept up as they run)
        self.limit = len(states)
        self.steps = 0

    def take(self, n: int, counters: EnergyCounters) -> int:
        """Up to `n` more steps, no further than `limit`: how many it took (away from home: nothing is charged)."""
        taken = max(0, min(n, self.limit - self.steps))
        self.steps += taken
        return taken

    def state(self) -> VehicleState:
        return self.after(self.steps)

    def after(self, n: int) -> VehicleState:
        """The hull after `n` steps (0 <= n <= `limit`)."""
        return self.origin if n == 0 else self._states[n - 1]

    def primitive(self) -> PrimitiveState:
        """The primitive after `steps` steps (its timers as ticking leaves them)."""
        return self.origin_primitive if self.steps == 0 else self._primitives[self.steps - 1]


def found(origin: VehicleState, primitive: PrimitiveState, params: ApadParams, current_mps: tuple[float, float],
          mussels: Mapping[int, MusselFix], fixes: tuple[MusselFix | None, ...], dt_s: float,
          key: tuple[object, ...] = ()) -> Track | None:
    """The track of an armed hull from `origin` under `primitive` (both as the last tick left them, the energy
    meter not charging), or None if it would be shorter than `MIN_STEPS`."""
    p = params
    states: list[VehicleState] = []
    primitives: list[PrimitiveState] = []
    before, current = origin, primitive
    for _ in range(MAX_STEPS):
        if before.battery_v <= BATTERY_EMPTY_V:
            break
        state = veh.step(before, prim.velocity_setpoint(current, before, p), p, current_mps, dt_s)
        if at_rest(before, state) or could_charge(state, p):
            break
        new = prim.step(current, state.x_m, state.y_m, mussels, p, dt_s)
        if new is not current and not timers_only(current, new):
            break
        states.append(state)
        primitives.append(new)
        before, current = state, new
    if len(states) < MIN_STEPS:
        return None
    return Track(origin, primitive, states, primitives, dt_s, fixes, key)
