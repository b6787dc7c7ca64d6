"""The aPad's physics task, one tick: a step of the hull and its primitive, or one more step of its rest.

The vehicle core (endpoint.py) calls `step_hull` at the physics rate with the parts it owns; the
models stay pure (vehicle, primitives, rest), and the energy meter takes its share of each step.
"""

from __future__ import annotations

from apad_sitl import primitives as prim
from apad_sitl import rest as rest_mod
from apad_sitl import vehicle as veh
from apad_sitl.docking import MusselFixTable
from apad_sitl.energy import EnergyMeter
from apad_sitl.state import ApadState


def step_hull(apad: ApadState, energy: EnergyMeter, mussels: MusselFixTable,
              current_mps: tuple[float, float], dt_s: float) -> None:
    """Advance the hull `dt_s`: in closed form while its rest holds, else stepped (and maybe at rest)."""
    p, primitive = apad.params, apad.primitive
    key = rest_key(apad, current_mps)
    if apad.rest is not None:
        if rest_steps(apad, energy, key, dt_s, 1) == 1:
            return
        apad.state = apad.state  # something that moves the hull changed: the rest's state, stepped from here
    before = apad.state
    setpoint = prim.velocity_setpoint(primitive, before, p) if apad.armed else (0.0, 0.0)
    apad.state = state = veh.step(before, setpoint, p, current_mps, dt_s)
    home_wh = energy.step(dt_s)
    apad.set_primitive(prim.step(primitive, state.x_m, state.y_m, mussels, p, dt_s))
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
        apad.rest = rest_mod.ChargingRest(apad.state, p, dt_s, key)


def rest_key(apad: ApadState, current_mps: tuple[float, float]) -> tuple[object, ...]:
    """What a rest holds for: a change of any of these ends it."""
    return (apad.primitive, apad.params, apad.armed, current_mps)


def rest_holds(apad: ApadState, key: tuple[object, ...], dt_s: float) -> bool:
    """Whether the hull rests, for `key` (`rest_key`) and in steps of `dt_s`."""
    rest = apad.rest
    return rest is not None and rest.key == key and rest.dt_s == dt_s


def rest_steps(apad: ApadState, energy: EnergyMeter, key: tuple[object, ...], dt_s: float, n: int) -> int:
    """Up to `n` more steps of `dt_s` of the hull's rest, if it still holds (`rest_holds`): how many it
    took (0: it does not hold; fewer than `n`: a charging rest's battery came to full)."""
    rest = apad.rest
    if rest is None or not rest_holds(apad, key, dt_s):
        return 0
    return rest.take(n, energy.counters)
