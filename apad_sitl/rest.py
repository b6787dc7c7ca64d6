"""A hull at rest, advanced in closed form: a holding aPad costs nothing per physics step.

An aPad holding at its hold point in slack water reaches a fixed point of `vehicle.step`: the
velocities flush to 0 (`vehicle._snap`), the position and heading stop changing, and every further
step only takes the same drain from the battery (the hotel load, plus the thrust of a setpoint too
small to move the hull). Once one step leaves the hull as it found it but for the battery
(`at_rest`), the vehicle's core stops stepping it and counts the steps instead (`Rest`): the state
after n more steps is the origin with n drains taken, clamped at empty, in closed form. The result
equals stepping to float rounding (a product for a sum of n terms; tests/unit/test_sitl_rest.py).

At its home charger with the battery full, the hull reaches a fixed point of the whole step: the
charger puts back exactly what the step drained (the battery ends each step where it began). The
rest then drains nothing (`refill_wh`: the home energy each step puts back, which the core still
adds to the counters step by step, so they are what stepping makes to the last bit).

At its home charger below full, the hull is still and only the battery changes: a `ChargingRest`
takes each step as a few float operations (the drain of `vehicle.step` at rest, then the charger's
step from `home_charger`), the same floats stepping makes, until the battery is full. On the ideal
link (`closed`) it takes the steps before the last one in closed form too: each is the same rise (the
charger's power less the hotel drain), a product for a sum, to float rounding; the step that tops the
battery up is stepped.

Pure: no clock, no I/O; `dt_s` is the physics step the rest was found at.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import replace

from apad_sitl.energy_counters import EnergyCounters
from apad_sitl.home_charger import home_charge_wh, volts_after
from apad_sitl.hull_at import HullAt
from apad_sitl.params import ApadParams
from apad_sitl.vehicle import BATTERY_EMPTY_V, BATTERY_FULL_V, VOLT_RANGE, VehicleState, drain_v

NEVER_STEPS = 2**62  # `Rest.still_from` of a drain that would take longer than any mission: ages of steps
# A closed charging rest's steps short of full left to stepping: the float rounding of its product cannot
# carry the battery past full, and the step that tops it up is the charger's own arithmetic.
TOP_UP_STEPS = 2


def at_rest(before: VehicleState, after: VehicleState) -> bool:
    """True if a step from `before` to `after` changed nothing but the battery: a fixed point."""
    return (
        after.x_m == before.x_m and after.y_m == before.y_m
        and after.vx_mps == before.vx_mps == 0.0 and after.vy_mps == before.vy_mps == 0.0
        and after.water_vx_mps == before.water_vx_mps and after.water_vy_mps == before.water_vy_mps
        and after.heading_rad == before.heading_rad and after.yaw_rate_radps == before.yaw_rate_radps
        and after.thrust_mps2 == before.thrust_mps2
        and after.distance_travelled_m == before.distance_travelled_m
    )


class Rest:
    """The hull at rest since `origin` (the state after the step that found the fixed point).

    `steps` counts the physics steps of `dt_s` taken since; `state()` is the hull after them.
    """

    __slots__ = ("_drain_v", "_hull", "dt_s", "key", "origin", "refill_wh", "steps")

    def __init__(self, origin: VehicleState, params: ApadParams, dt_s: float, key: tuple[object, ...] = (),
                 refill_wh: float | None = None) -> None:
        self.origin = origin
        self.dt_s = dt_s
        self.key = key  # what it holds for (the core's primitive, parameters, arming, current): a change ends it
        self.steps = 0
        # Not None: held full at the home charger, which puts back this much each step (nothing drains).
        self.refill_wh = refill_wh
        self._drain_v = 0.0 if refill_wh is not None else drain_v(params, origin.thrust_mps2, dt_s)
        self._hull = HullAt(origin)

    def take(self, n: int, counters: EnergyCounters) -> int:
        """`n` more steps (the home charger's top-ups added to `counters` one by one, as stepping adds
        them); all of them, always."""
        self.steps += n
        if self.refill_wh is not None:
            for _ in range(n):
                counters.home_wh += self.refill_wh
        return n

    def state(self) -> VehicleState:
        """The hull after `steps` more steps: the battery drained `steps` times, clamped at empty."""
        return self._hull.at(self.steps, self.after)

    def after(self, n: int) -> VehicleState:
        """The hull after `n` steps of the rest (what `state` is once `steps` is `n`); changes nothing."""
        o = self.origin
        battery_v = max(BATTERY_EMPTY_V, o.battery_v - n * self._drain_v)
        # A flat battery stops the thrusters: from the step after it emptied, the thrust is 0 (as stepped).
        thrust = 0.0 if o.battery_v - (n - 1) * self._drain_v <= BATTERY_EMPTY_V else o.thrust_mps2
        return replace(o, battery_v=battery_v, thrust_mps2=thrust)

    def still_from(self) -> int:
        """The step count from which the hull changes no more: 0 if nothing drains (held full at the
        charger) or it is flat already, else the step after the battery went flat (the thrust is 0 from then)."""
        o, drain = self.origin, self._drain_v
        if drain <= 0.0:
            return 0
        # The first n with o.battery_v - (n - 1) * drain <= empty (the very test `after` makes; monotone in n):
        # bisected between 0 and a bound doubled from the estimate, exact whatever the floats' rounding.
        def flat(n: int) -> bool:
            return o.battery_v - (n - 1) * drain <= BATTERY_EMPTY_V

        estimate = (o.battery_v - BATTERY_EMPTY_V) / drain
        if not estimate < NEVER_STEPS:  # a drain too small to empty it in any mission (or a float's range)
            return NEVER_STEPS
        hi = max(1, math.ceil(estimate) + 1)
        while not flat(hi) and hi < NEVER_STEPS:
            hi *= 2
        return bisect.bisect_left(range(hi), True, key=flat)  # hi itself: flat(hi), or NEVER_STEPS reached


class ChargingRest:
    """The hull still at its home charger, charging: each step changes the battery alone, drained as
    `vehicle.step` drains it at rest and charged as `energy.EnergyMeter.step` charges it (the same
    floats, step by step: `home_charger`), until it is full (then it is stepped, and rests held full,
    `Rest`). Hours of charging cost a few float operations a step, not a physics step.
    """

    __slots__ = (
        "_charge_wh",
        "_drain_v",
        "_hull",
        "_params",
        "_rise_v",
        "battery_v",
        "closed",
        "dt_s",
        "key",
        "origin",
        "steps",
    )

    def __init__(self, origin: VehicleState, params: ApadParams, dt_s: float, key: tuple[object, ...] = (),
                 closed: bool = False) -> None:
        self.origin = origin
        self.dt_s = dt_s
        self.key = key
        self.steps = 0
        self.battery_v = origin.battery_v
        self.closed = closed  # the steps before the last in closed form (the ideal link's)
        self._params = params
        self._drain_v = drain_v(params, origin.thrust_mps2, dt_s)
        self._charge_wh = params.home_charge_w * dt_s / 3600.0  # a step's charge below full (`home_charge_wh`)
        self._rise_v = self._charge_wh / params.batt_capacity_wh * VOLT_RANGE - self._drain_v
        self._hull = HullAt(origin)

    def _whole_steps(self, v: float) -> int:
        """Steps from `v` at the charger's whole power that leave the battery below full (a margin short of
        the last, which the float rounding of the product could otherwise move)."""
        if self._rise_v <= 0.0 or not BATTERY_EMPTY_V < v < BATTERY_FULL_V:
            return 0
        return max(0, math.ceil((BATTERY_FULL_V - v) / self._rise_v) - TOP_UP_STEPS)

    def take(self, n: int, counters: EnergyCounters) -> int:
        """Up to `n` more steps; fewer (the number taken) if a step would not charge: full, or flat."""
        if self.closed:
            whole = min(n, self._whole_steps(self.battery_v))
            self.battery_v += whole * self._rise_v
            counters.home_wh += whole * self._charge_wh
            self.steps += whole
            return whole + self._stepped(n - whole, counters)
        return self._stepped(n, counters)

    def _stepped(self, n: int, counters: EnergyCounters) -> int:
        v, p, dt_s, drain = self.battery_v, self._params, self.dt_s, self._drain_v
        for taken in range(n):
            drained = max(BATTERY_EMPTY_V, v - drain)
            if not BATTERY_EMPTY_V < v < BATTERY_FULL_V or not drained < BATTERY_FULL_V:  # flat, or full: stepped
                self.battery_v = v
                return taken
            wh = home_charge_wh(drained, p, dt_s)
            counters.home_wh += wh
            v = volts_after(drained, wh, p)
            self.steps += 1
        self.battery_v = v
        return n

    def state(self) -> VehicleState:
        return self._hull.at(self.steps, lambda _: replace(self.origin, battery_v=self.battery_v))

    def after(self, n: int) -> VehicleState:
        """The hull after `n` steps of the rest (`n` at least those taken) in the closed form: full once its
        whole-power steps are done (the few stepped after them top it up); changes nothing."""
        ahead, whole = max(0, n - self.steps), self._whole_steps(self.battery_v)
        v = self.battery_v + ahead * self._rise_v if ahead <= whole else BATTERY_FULL_V
        return replace(self.origin, battery_v=min(BATTERY_FULL_V, v))

    def still_from(self) -> int:
        """The step count from which the battery is full (the closed form's estimate: the whole-power steps
        and the few stepped after them)."""
        return self.steps + self._whole_steps(self.battery_v) + TOP_UP_STEPS + 1
