"""A hull at rest while latch timers run (a Dock or an Undock), advanced in closed form.

While a Dock's or an Undock's latch closes or opens, the aPad holds its point: once the hull is at
its fixed point (`rest.at_rest`), a step changes only the battery (the rest's drain, or nothing held
full at the home charger) and the timers of the latches under way. Nothing else of the primitive can
change while the hull is still: a timer completes at a step computable from its value, and a closing
latch's aMussel leaves reach only by a status heard (a message, which ends the hold: its fix is part
of what the hold holds for, `fixes`). So `LatchHold` takes the steps up to the last before a timer
completes (`limit`): the hull as `rest.Rest` leaves it, the timers as stepping leaves them (the same
subtraction, step by step: a few float operations, to the bit). The step that completes a timer is
stepped, on the tick stepping takes it.

Pure: no clock, no I/O. Only on the ideal link (`SitlVehicle(ideal_link=True)`): lockstep steps every tick.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

from apad_sitl.energy_counters import EnergyCounters
from apad_sitl.primitives import MusselFix, PrimitiveState
from apad_sitl.rest import Rest
from apad_sitl.vehicle import VehicleState
from apad_sitl.vocabulary import Latch

_TIMED = (Latch.CLOSING, Latch.RELEASING)


def timed(primitive: PrimitiveState) -> bool:
    """Whether a latch timer runs (a slot closing or releasing)."""
    return any(s.latch in _TIMED for s in primitive.slots)


def timers_only(old: PrimitiveState, new: PrimitiveState) -> bool:
    """Whether a step from `old` to `new` changed latch timers and nothing else."""
    if new.slots == old.slots or replace(new, slots=old.slots) != old:
        return False
    return all(a.mussel_id == b.mussel_id and a.latch == b.latch and a.charging == b.charging
               for a, b in zip(old.slots, new.slots, strict=True))


def closing_fixes(primitive: PrimitiveState, mussels: Mapping[int, MusselFix]) -> tuple[MusselFix | None, ...]:
    """The fixes a closing latch checks its aMussel's reach against, one per closing slot."""
    return tuple(mussels.get(s.mussel_id) for s in primitive.slots if s.latch == Latch.CLOSING)


class LatchTimers:
    """The latch timers of `origin` (a primitive) as `primitives.step` runs them, step by step: `limit` is
    the last step before one completes (None: none runs), `after(n)` the primitive n steps on."""

    __slots__ = ("_cache", "dt_s", "limit", "origin")

    def __init__(self, origin: PrimitiveState, dt_s: float) -> None:
        self.origin = origin
        self.dt_s = dt_s
        running = [_steps_before_done(s.timer_s, dt_s) for s in origin.slots if s.latch in _TIMED]
        self.limit = min(running) if running else None
        self._cache = (0, origin)

    def after(self, n: int) -> PrimitiveState:
        """The primitive after `n` steps (n <= `limit`): each running timer less `dt_s` once a step, the
        same subtraction (kept from the last asked: a few subtractions a step)."""
        done, primitive = self._cache
        if done == n or self.limit is None:
            return primitive
        if done > n:
            done, primitive = 0, self.origin
        slots = []
        for s in primitive.slots:
            if s.latch in _TIMED:
                timer = s.timer_s
                for _ in range(n - done):
                    timer = timer - self.dt_s
                s = replace(s, timer_s=timer)
            slots.append(s)
        primitive = replace(primitive, slots=tuple(slots))
        self._cache = (n, primitive)
        return primitive


class LatchHold:
    """The hull at rest (`hull`, a `rest.Rest` from the same origin) while the latch timers of `primitive`
    run: `steps` counts the steps of `dt_s` taken since, at most `limit` (the last before a timer completes).
    """

    __slots__ = ("dt_s", "fixes", "hull", "key", "limit", "steps", "timers")

    def __init__(self, hull: Rest, primitive: PrimitiveState, fixes: tuple[MusselFix | None, ...],
                 key: tuple[object, ...] = ()) -> None:
        self.hull = hull
        self.dt_s = hull.dt_s
        self.key = key  # what it holds for (as a rest's key; the primitive's timers kept up as they run)
        self.fixes = fixes  # the closing latches' aMussels as the hold began: a status that moves one ends it
        self.steps = 0
        self.timers = LatchTimers(primitive, self.dt_s)
        self.limit = self.timers.limit or 0

    def take(self, n: int, counters: EnergyCounters) -> int:
        """Up to `n` more steps, no further than `limit`: how many it took."""
        taken = max(0, min(n, self.limit - self.steps))
        self.hull.take(taken, counters)
        self.steps += taken
        return taken

    def state(self) -> VehicleState:
        return self.hull.state()

    def primitive(self) -> PrimitiveState:
        """The primitive after `steps` steps (its timers as stepping leaves them)."""
        return self.timers.after(self.steps)


def _steps_before_done(timer_s: float, dt_s: float) -> int:
    """The steps a latch timer at `timer_s` runs before the one that completes it (`primitives.step`: the
    step that finds `timer_s - dt_s <= 0`)."""
    n = 0
    while timer_s - dt_s > 0.0:
        timer_s -= dt_s
        n += 1
    return n
