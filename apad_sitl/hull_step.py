"""The aPad's physics task, one tick: a step of the hull and its primitive, or one more step of its rest.

The vehicle core (endpoint.py) calls `step_hull` at the physics rate with the parts it owns; the
models stay pure (vehicle, primitives, rest, cruise, latch_hold), and the energy meter takes its share
of each step. With `closed_forms` (the ideal link's) a busy hull is advanced in closed form too: a Go
To's steady cruise (`cruise.Cruise`) and a hull held still while latch timers run
(`latch_hold.LatchHold`), each up to the last step before something could change otherwise, and where
no equation holds, the hull stepped ahead (`track.Track`).
"""

from __future__ import annotations

from collections.abc import Mapping

from apad_sitl import cruise as cruise_mod
from apad_sitl import latch_hold as hold_mod
from apad_sitl import primitives as prim
from apad_sitl import rest as rest_mod
from apad_sitl import settling as settling_mod
from apad_sitl import track as track_mod
from apad_sitl import vehicle as veh
from apad_sitl.energy import EnergyMeter
from apad_sitl.primitives import MusselFix
from apad_sitl.state import ApadState

# The closed forms that end at a step of their own (`limit`), after which the hull is stepped.
BOUNDED = (cruise_mod.Cruise, hold_mod.LatchHold, settling_mod.Settling, track_mod.Track)
_TIMED = (hold_mod.LatchHold, settling_mod.Settling, track_mod.Track)  # the closed forms that run latch timers


def step_hull(apad: ApadState, energy: EnergyMeter, mussels: Mapping[int, MusselFix],
              current_mps: tuple[float, float], dt_s: float, closed_forms: bool = False) -> None:
    """Advance the hull `dt_s`: in closed form while its rest holds, else stepped (and maybe at rest)."""
    p, primitive = apad.params, apad.primitive
    key = rest_key(apad, current_mps)
    if apad.rest is not None:
        if rest_steps(apad, energy, mussels, current_mps, dt_s, 1) == 1:
            return
        apad.state = apad.state  # something that moves the hull changed: the rest's state, stepped from here
        primitive = apad.primitive
    before = apad.state
    setpoint = prim.velocity_setpoint(primitive, before, p) if apad.armed else (0.0, 0.0)
    apad.state = state = veh.step(before, setpoint, p, current_mps, dt_s)
    home_wh = energy.step(dt_s)
    apad.set_primitive(prim.step(primitive, state.x_m, state.y_m, mussels, p, dt_s))
    if closed_forms and apad.state is state:
        _find_closed_form(apad, energy, mussels, before, primitive, current_mps, dt_s)
    # A fixed point (holding at the hold point in slack water, no latch timer running; away from the
    # home charger, or at it with the battery held full): rest until the primitive, the parameters,
    # arming or the current change, or a battery draw writes the state (apad_sitl.rest).
    if apad.primitive is not primitive or not rest_mod.at_rest(before, apad.state):
        return
    if not energy.could_charge():
        if apad.state is state:
            apad.rest = rest_mod.Rest(state, p, dt_s, key)
    elif apad.state.battery_v == before.battery_v:  # the charger put back exactly what the step drained
        apad.rest = rest_mod.Rest(apad.state, p, dt_s, key, refill_wh=home_wh)
    elif energy.counters.charging:  # still at the charger, charging: the battery alone changes
        apad.rest = rest_mod.ChargingRest(apad.state, p, dt_s, key, closed=closed_forms)


def _find_closed_form(apad: ApadState, energy: EnergyMeter, mussels: Mapping[int, MusselFix],
                      before: veh.VehicleState, primitive: prim.PrimitiveState, current_mps: tuple[float, float],
                      dt_s: float) -> None:
    """After a step from `before` under `primitive` (the battery untouched since): a cruise, a settling or a
    latch hold from here, if the step was one of them and an armed hull's (the ideal link's closed forms)."""
    new, state, p = apad.primitive, apad.state, apad.params
    if not apad.armed or not (new is primitive or hold_mod.timers_only(primitive, new)):
        return
    key = rest_key(apad, current_mps)
    fixes = hold_mod.closing_fixes(new, mussels)
    if rest_mod.at_rest(before, state):
        if new is not primitive and not energy.could_charge():
            hold = hold_mod.LatchHold(rest_mod.Rest(state, p, dt_s), new, fixes, key)
            if hold.limit > 1:
                apad.rest = hold
        return  # else a rest, if any (`step_hull`)
    found: cruise_mod.Cruise | settling_mod.Settling | track_mod.Track | None = None
    if new is primitive:
        found = cruise_mod.found(before, state, new, p, dt_s, key)
    if found is None:
        found = settling_mod.found(before, state, new, p, current_mps, mussels, p.home_charge_w > 0.0, dt_s, fixes,
                                   key)
    if found is None and not energy.counters.charging:  # no equation holds: stepped ahead
        found = track_mod.found(state, new, p, current_mps, mussels, fixes, dt_s, key)
    apad.rest = found


def rest_key(apad: ApadState, current_mps: tuple[float, float]) -> tuple[object, ...]:
    """What a rest holds for: a change of any of these ends it."""
    return (apad.primitive, apad.params, apad.armed, current_mps)


def rest_holds(apad: ApadState, mussels: Mapping[int, MusselFix], current_mps: tuple[float, float],
               dt_s: float) -> bool:
    """Whether the hull rests, for what it holds for (`rest_key`) and in steps of `dt_s` (a latch hold also
    for the fixes of the aMussels its closing latches check)."""
    rest = apad.rest
    if rest is None or rest.key != rest_key(apad, current_mps) or rest.dt_s != dt_s:
        return False
    return not isinstance(rest, _TIMED) or hold_mod.closing_fixes(apad.primitive, mussels) == rest.fixes


def rest_steps(apad: ApadState, energy: EnergyMeter, mussels: Mapping[int, MusselFix],
               current_mps: tuple[float, float], dt_s: float, n: int) -> int:
    """Up to `n` more steps of `dt_s` of the hull's rest, if it still holds (`rest_holds`): how many it
    took (0: it does not hold; fewer than `n`: a charging rest's battery came to full, a closed form's end)."""
    rest = apad.rest
    if rest is None or not rest_holds(apad, mussels, current_mps, dt_s):
        return 0
    taken = rest.take(n, energy.counters)
    if taken and isinstance(rest, _TIMED):  # its timers ran: the primitive as stepping leaves it
        apad.set_primitive(rest.primitive())
        rest.key = rest_key(apad, current_mps)
    return taken

