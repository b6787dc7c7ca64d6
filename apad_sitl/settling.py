"""A hull settling onto the point its primitive holds, advanced in closed form (the ideal link's).

Within HOLD_KP's zone of its target (where HOLD_KP * dist is below both the speed and
sqrt(ACCEL_MAX * dist): `primitives.velocity_setpoint`), in slack water, below the acceleration bound
and too slow for the bow to turn (HEADING_MIN_SPEED), a step of `vehicle.step` is linear in the hull's
state, each axis apart: with e the offset from the target to the hull's east (or north) position's
complement and w the water velocity (the ground's, in slack water),

    w' = c e - kd w,        e' = e - dt w',        c = HOLD_KP (1 + HOLD_KD),

so n steps on the state is A^n (e, w): two geometric modes, with the eigenvalues of A (real, of
modulus below 1). That is the long tail of every arrival (a Go To's last metre and the minute its
velocity takes to decay to nothing, `rest.at_rest`), and most of what a Dock or an Undock holds. The
battery's drain over n steps is a sum of squares of the modes (geometric sums); the odometer adds a
hypotenuse a step (a few float operations, kept from the last asked). The closed form stops short of
every step where the law changes (the zone's edge, the acceleration bound, the bow's speed, a target
nearer than `primitives.velocity_setpoint`'s 1e-9 m, the victory radius of a primitive under way, a
latch timer's end, a closing latch's reach, the home charger) by bounding each mode by its start.

Stepping makes the same states to float noise (it rounds the position at every step). Pure: no clock,
no I/O. Only on the ideal link (`SitlVehicle(ideal_link=True)`): lockstep steps every tick.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import replace

from apad_sitl.energy_counters import EnergyCounters
from apad_sitl.hull_at import HullAt
from apad_sitl.latch_hold import LatchTimers
from apad_sitl.params import ApadParams
from apad_sitl.primitives import MusselFix, PrimitiveState
from apad_sitl.vehicle import BATTERY_EMPTY_V, HEADING_MIN_SPEED_MPS, VehicleState
from apad_sitl.vocabulary import Latch, Primitive, Progress

SAFE = 1.0 - 1e-6  # a bound is kept with this much to spare
NEAREST_M = 2e-9  # the target never nearer (velocity_setpoint's direction is 0 within 1e-9 m)
MAX_STEPS = 1_000_000


class Settling:
    """The hull settling since `origin` (the state after the step that found it), its latch timers running.

    `steps` counts the steps of `dt_s` taken since, at most `limit`; `state()` is the hull after them,
    `primitive()` the primitive.
    """

    __slots__ = ("_hull", "_lam", "_modes", "_odo", "_p", "_sq", "_t0", "dt_s", "fixes", "key", "limit", "origin",
                 "steps", "timers")

    def __init__(self, origin: VehicleState, primitive: PrimitiveState, params: ApadParams, dt_s: float,
                 lam: tuple[float, float], modes: tuple[tuple[float, float, float, float], ...],
                 fixes: tuple[MusselFix | None, ...], key: tuple[object, ...] = ()) -> None:
        """`modes`: per axis (east, north), the offset's and the velocity's coefficients of each eigenvalue
        (e1, w1, e2, w2): e_n = e1 l1^n + e2 l2^n, w_n = w1 l1^n + w2 l2^n."""
        self.origin = origin
        self.dt_s = dt_s
        self.key = key
        self.fixes = fixes
        self.steps = 0
        self.limit = 0
        self.timers = LatchTimers(primitive, dt_s)
        self._p = params
        self._lam = lam
        self._modes = modes
        self._t0 = (primitive.target_x_m, primitive.target_y_m)
        self._odo = (0, origin.distance_travelled_m)
        self._sq = _thrust_squares(params, dt_s, lam, modes)
        self._hull = HullAt(origin)

    def take(self, n: int, counters: EnergyCounters) -> int:
        """Up to `n` more steps, no further than `limit`: how many it took (nothing is charged or passed)."""
        taken = max(0, min(n, self.limit - self.steps))
        self.steps += taken
        return taken

    def primitive(self) -> PrimitiveState:
        return self.timers.after(self.steps)

    def state(self) -> VehicleState:
        return self._hull.at(self.steps, self.after)

    def _axis(self, n: int) -> tuple[float, float, float, float]:
        """(e east, e north, w east, w north) after `n` steps."""
        l1n, l2n = self._lam[0] ** n, self._lam[1] ** n
        (ex1, wx1, ex2, wx2), (ey1, wy1, ey2, wy2) = self._modes
        return ex1 * l1n + ex2 * l2n, ey1 * l1n + ey2 * l2n, wx1 * l1n + wx2 * l2n, wy1 * l1n + wy2 * l2n

    def after(self, n: int) -> VehicleState:
        """The hull after `n` steps (1 <= n <= `limit`; 0: the origin); changes nothing but the odometer's cache."""
        if n == 0:
            return self.origin
        o, p, dt_s = self.origin, self._p, self.dt_s
        ex, ey, wx, wy = self._axis(n)
        _, _, pwx, pwy = self._axis(n - 1)
        tx, ty = (wx - pwx) / dt_s + p.drag_per_s * wx, (wy - pwy) / dt_s + p.drag_per_s * wy
        return replace(
            o, x_m=self._t0[0] - ex, y_m=self._t0[1] - ey, vx_mps=wx, vy_mps=wy, water_vx_mps=wx, water_vy_mps=wy,
            yaw_rate_radps=0.0, thrust_mps2=math.hypot(tx, ty), battery_v=self.battery_after(n),
            distance_travelled_m=self._odometer(n))

    def battery_after(self, n: int) -> float:
        """The battery after `n` steps: each drains the hotel load and the thrust's square (`vehicle.drain_v`)."""
        p, dt_s = self._p, self.dt_s
        drained = (n * p.batt_drain_idle_vph + p.batt_drain_thrust_vph * self._sq(n)) * dt_s / 3600.0
        return max(BATTERY_EMPTY_V, self.origin.battery_v - drained)

    def _odometer(self, n: int) -> float:
        done, total = self._odo
        if done > n:
            done, total = 0, self.origin.distance_travelled_m
        l1, l2 = self._lam
        (_, wx1, _, wx2), (_, wy1, _, wy2) = self._modes
        l1k, l2k = l1 ** (done + 1), l2 ** (done + 1)
        dt_s = self.dt_s
        for _ in range(n - done):
            total += math.hypot(wx1 * l1k + wx2 * l2k, wy1 * l1k + wy2 * l2k) * dt_s
            l1k, l2k = l1k * l1, l2k * l2
        self._odo = (n, total)
        return total


def _thrust_squares(p: ApadParams, dt_s: float, lam: tuple[float, float],
                    modes: tuple[tuple[float, float, float, float], ...]) -> Callable[[int], float]:
    """S(n): the sum over steps 1..n of the thrust squared (both axes), in closed form: a step's thrust per
    axis is (w_k - w_(k-1)) / dt + drag w_k, t1 l1^(k-1) + t2 l2^(k-1) with each mode's coefficient."""
    l1, l2 = lam
    coefs = []
    for _, w1, _, w2 in modes:
        coefs.append((w1 * ((l1 - 1.0) / dt_s + p.drag_per_s * l1), w2 * ((l2 - 1.0) / dt_s + p.drag_per_s * l2)))
    a = sum(t1 * t1 for t1, _ in coefs)
    b = sum(2.0 * t1 * t2 for t1, t2 in coefs)
    c = sum(t2 * t2 for _, t2 in coefs)

    def geometric(r: float, n: int) -> float:
        return float(n) if r == 1.0 else (1.0 - r ** n) / (1.0 - r)

    def squares(n: int) -> float:
        return a * geometric(l1 * l1, n) + b * geometric(l1 * l2, n) + c * geometric(l2 * l2, n)

    return squares


def found(before: VehicleState, after: VehicleState, primitive: PrimitiveState, params: ApadParams,
          current_mps: tuple[float, float], mussels: Mapping[int, MusselFix], home_charges: bool, dt_s: float,
          fixes: tuple[MusselFix | None, ...], key: tuple[object, ...] = ()) -> Settling | None:
    """The settling a step to `after` (under `primitive`, as that step left it) starts, or None if the law
    above does not hold from there for a few steps. `home_charges`: the home charger could charge where the
    hull might come (its power and home's reach are checked here too)."""
    p = params
    if primitive.kind == Primitive.IDLE or current_mps != (0.0, 0.0) or p.hold_kd <= 0.0 or p.hold_kp_per_s <= 0.0:
        return None
    if after.battery_v <= BATTERY_EMPTY_V or (after.vx_mps, after.vy_mps) != (after.water_vx_mps, after.water_vy_mps):
        return None
    if math.hypot(after.water_vx_mps, after.water_vy_mps) > HEADING_MIN_SPEED_MPS:
        return None  # the bow may still turn (and the modes' bound below could not hold): most steps of a move
    c = p.hold_kp_per_s * (1.0 + p.hold_kd)
    a11, a12, a21, a22 = 1.0 - dt_s * c, dt_s * p.hold_kd, c, -p.hold_kd
    tr, det = a11 + a22, a11 * a22 - a12 * a21
    disc = tr * tr - 4.0 * det
    if disc <= 0.0:
        return None
    root = math.sqrt(disc)
    l1, l2 = (tr + root) / 2.0, (tr - root) / 2.0
    if not (abs(l1) < 1.0 and abs(l2) < 1.0) or l1 == l2:
        return None
    # Eigenvectors (a12, l - a11); the state (e, w) of each axis in their basis.
    v1, v2 = (a12, l1 - a11), (a12, l2 - a11)
    vdet = v1[0] * v2[1] - v2[0] * v1[1]
    if vdet == 0.0:
        return None
    tx, ty = primitive.target_x_m, primitive.target_y_m
    modes = []
    for e, w in ((tx - after.x_m, after.water_vx_mps), (ty - after.y_m, after.water_vy_mps)):
        alpha = (e * v2[1] - v2[0] * w) / vdet
        beta = (v1[0] * w - e * v1[1]) / vdet
        modes.append((alpha * v1[0], alpha * v1[1], beta * v2[0], beta * v2[1]))
    (ex1, wx1, ex2, wx2), (ey1, wy1, ey2, wy2) = modes
    e1, e2 = math.hypot(ex1, ey1), math.hypot(ex2, ey2)  # each mode's size, offset and velocity
    w1, w2 = math.hypot(wx1, wy1), math.hypot(wx2, wy2)
    speed = p.speed_max_mps if primitive.kind != Primitive.GOTO or primitive.speed_mps <= 0.0 \
        else min(p.speed_max_mps, primitive.speed_mps)
    zone = min(speed / p.hold_kp_per_s, p.accel_max_mps2 / (p.hold_kp_per_s * p.hold_kp_per_s))
    # Each bound by the modes' sizes at the start (they only shrink): the zone, the bow, the acceleration.
    k = 1.0 + p.hold_kd  # |s - w| of each mode: its share of a step's change of velocity
    dv1, dv2 = math.hypot(c * ex1 - k * wx1, c * ey1 - k * wy1), math.hypot(c * ex2 - k * wx2, c * ey2 - k * wy2)
    if e1 + e2 > zone * SAFE or w1 + w2 > HEADING_MIN_SPEED_MPS * SAFE or dv1 + dv2 > p.accel_max_mps2 * dt_s * SAFE:
        return None
    if home_charges and math.hypot(tx, ty) - (e1 + e2) <= p.home_radius_m / SAFE:
        return None  # slow enough to charge at home, and maybe there
    for s in primitive.slots:
        if s.latch == Latch.CLOSING:
            fix = mussels.get(s.mussel_id)
            if fix is None or math.hypot(fix.x_m - tx, fix.y_m - ty) + e1 + e2 > p.dock_reach_m * SAFE:
                return None  # its aMussel could leave reach as the hull moves
    # The steps while the target stays further than NEAREST_M (and than the radius of a primitive under way).
    nearest = NEAREST_M
    if primitive.kind in (Primitive.GOTO, Primitive.HOLD) and primitive.progress == Progress.IN_PROGRESS:
        radius = primitive.radius_m if primitive.radius_m > 0.0 else p.wp_radius_m
        nearest = max(nearest, radius / SAFE)
    limit = _steps_further_than(nearest, e1, e2, abs(l1), abs(l2))
    timers = LatchTimers(primitive, dt_s)
    if timers.limit is not None:
        limit = min(limit, timers.limit)
    settling = Settling(after, primitive, p, dt_s, (l1, l2), tuple(modes), fixes, key)
    # The battery stays above empty throughout (a flat one stops the thrusters).
    while limit > 2 and settling.battery_after(limit) <= BATTERY_EMPTY_V + 1e-6:
        limit //= 2
    settling.limit = limit - 1  # one step to spare
    return settling if settling.limit > 2 else None


def _steps_further_than(nearest: float, e1: float, e2: float, l1: float, l2: float) -> int:
    """The most steps n with e1 l1^k - e2 l2^k > `nearest` for every k <= n (a lower bound of the offset)."""
    if e1 * SAFE - e2 <= nearest:
        return 0
    n, m1, m2 = 0, e1, e2
    while n < MAX_STEPS:
        m1, m2 = m1 * l1, m2 * l2
        if m1 * SAFE - m2 <= nearest:
            return n
        n += 1
    return n
