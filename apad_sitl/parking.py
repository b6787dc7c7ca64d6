"""The aPad's physics task: a tick every 1/physics_hz of mission time, or none while the hull rests.

A holding aPad's hull rests at a fixed point (`apad_sitl.rest`): each tick only counts one more
step of the rest and checks the GCS failsafe, which cannot act on a hull that is not busy. In a
long mission the aPads hold most of the time, and those ticks, ten a second each, were the world's
largest share of a quiet second. So while the hull rests and its primitive is not busy, the task is
parked: taken off the scheduler, its ticks skipped. They are taken when they matter, as stepping
would have left them:

- before what they change is read and before what they step on is written: `ApadState`'s accessors
  settle (the hull and the energy counters read by a stream, a checkpoint, the outcome; the hull,
  the parameters, the current, the primitive, mode and arming written);
- before anything is sent or logged (stamps and signing read the vehicle's time), and before and
  after the messages of a poll are handled: after, the task is back on the scheduler at its next
  tick, on the grid it never left, if what was handled ended the rest (only a message changes
  what a rest holds for, or a setter of the vehicle's, which settles first);
- at `stop` (the vehicle closes: the ticks up to then ran, as they would have).

Which ticks would have run by now is the scheduler's to say (`Scheduler.now_us` and `running`):
every tick before this instant, and this instant's too unless the task now running comes before
the physics task in the instant's order. The skipped ticks are taken in closed form
(`hull_step.rest_steps`: the rest's step count, the home charger's top-ups added one by one, a
charging rest's battery step by step until it is full; from there they are stepped); the
failsafe is checked at the first and the last of them (only its `failsafe_active` reset can act,
and whether the link is lost only changes once between two messages). Should the rest not hold
for them after all (its key changed without a message: a test setting a parameter), they are
stepped one by one. The result is the one ticking gives, to the bit.

On the ideal link the telemetry streams park with the task (`apad_sitl.streams`): `ahead` tells
them what the rest holds ahead (the hull at an instant, in closed form), and `on_rearm` wakes them
when the task ticks again.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Protocol

from apad_sitl.docking import MusselFixTable
from apad_sitl.energy import EnergyMeter
from apad_sitl.hull_step import BOUNDED, rest_holds, rest_steps, step_hull
from apad_sitl.logs import VehicleLog
from apad_sitl.modes import Modes
from apad_sitl.rest import ChargingRest, Rest
from apad_sitl.state import ApadState
from apad_sitl.vehicle import BATTERY_FULL_V, VehicleState
from apad_sitl.vocabulary import Primitive, Progress
from missiontime import US_PER_S, Scheduler, Task


class TickHost(Protocol):
    """What a tick works with: the vehicle core's parts (`apad_sitl.endpoint.SitlVehicle`)."""

    apad: ApadState
    energy: EnergyMeter
    mussels: MusselFixTable
    modes: Modes
    now_us: int
    log: VehicleLog | None


class PhysicsTicks:
    """The physics task of one vehicle on `scheduler`, parked while its hull rests."""

    def __init__(self, host: TickHost, scheduler: Scheduler, rate_hz: float, name: str, start_us: int,
                 park: bool = True, closed_forms: bool = False) -> None:
        """`park` False: a tick at every period, at rest too (what parking must equal). `closed_forms`: a busy
        hull advanced in closed form too (the ideal link's: `hull_step.step_hull`)."""
        self._host = host
        self._park = park
        self._closed_forms = closed_forms
        self._scheduler = scheduler
        self.task: Task = scheduler.every(1.0 / rate_hz, self.tick, name, start_us)
        self.last_us: int | None = None  # the last tick taken (run, or skipped and settled)
        self.parked = False
        self.parks = 0  # times the task was taken off the scheduler (figures for bench/ and tests:
        self.ticks = 0  # and the ticks it ran)
        self.on_rearm: Callable[[], None] | None = None  # told when a rest ends and the task ticks again

    def tick(self, now_us: int) -> None:
        self.ticks += 1
        host = self._host
        if self.parked:  # woken at a closed form's end: the ticks before this one taken in it, this one stepped
            self._take_skipped()
            self._unpark()
        host.now_us = now_us
        last, self.last_us = self.last_us, now_us
        if last is None:
            return
        self._step(last, now_us)
        apad = host.apad
        rest = apad.rest
        if not self._park or rest is None or not rest.steps:  # parked only once a rest held for a whole tick
            return
        if isinstance(rest, BOUNDED):  # a closed form with an end: woken at the first tick it leaves to stepping
            if rest.limit > rest.steps and self._may_park():
                period = self.task.period_us
                self._scheduler.reschedule(self.task, next_us=now_us + (rest.limit - rest.steps + 1) * period)
                self._parked()
        elif not _busy(apad):
            self._scheduler.reschedule(self.task, active=False)
            self._parked()

    def _parked(self) -> None:
        self.parked = True
        self.parks += 1
        self._host.apad.pending = self.catch_up

    def _step(self, last_us: int, now_us: int) -> None:
        host = self._host
        if host.log is not None and now_us // US_PER_S != last_us // US_PER_S:
            host.log.flush()  # each second of mission time (at most every FLUSH_EVERY_WALL_S of wall time)
        apad = host.apad
        if apad.params.fs_gcs_enable:
            host.modes.check_failsafe()
        step_hull(apad, host.energy, host.mussels, apad.current_mps, (now_us - last_us) / US_PER_S, self._closed_forms)

    def settle(self) -> None:
        """Take the ticks skipped so far (see the module's docstring); parked still if the rest holds."""
        if not self.parked:
            return
        self._take_skipped()
        if self._rest_holds():
            self._host.apad.pending = self.catch_up
        else:  # what was handled or set since the last tick ended the rest: ticking again from the next
            self._rearm()

    def catch_up(self) -> None:
        """What the skipped ticks change is read (or written, or stamped). On the ideal link, where the hull is
        read many times an instant while it cruises or settles in closed form, only if a tick is due: whether
        the rest still holds changes only with a message or a setter, each of which settles in full (`poll`,
        `ApadState.changed_while_parked`). Lockstep asks at every read, as it always has."""
        if self.parked and (not self._closed_forms or self._due() > 0):
            self.settle()

    def _due(self) -> int:
        """How many ticks would have run since the last taken (`settle`'s count)."""
        sched, task = self._scheduler, self.task
        running = sched.running
        upto = sched.now_us if running is None or running > task.order else sched.now_us - 1
        assert self.last_us is not None
        return (upto - self.last_us) // task.period_us

    def _take_skipped(self) -> None:
        host, task = self._host, self.task
        apad = host.apad
        apad.pending = None  # reading the hull below must not settle again
        last = self.last_us
        assert last is not None  # parked after a tick that stepped
        period = task.period_us
        n = self._due()
        if n <= 0:
            return
        now_before, end = host.now_us, last + n * period
        taken = rest_steps(apad, host.energy, host.mussels, apad.current_mps, period / US_PER_S, n)
        if taken:
            if apad.params.fs_gcs_enable:
                for t in sorted({last + period, last + taken * period}):  # the first and the last
                    host.now_us = t
                    host.modes.check_failsafe()
            if host.log is not None and last // US_PER_S != (last + taken * period) // US_PER_S:
                host.log.flush()
        # The rest's end (a charging battery come to full, a closed form's last step), or its key changed
        # without a message: stepped.
        for t in range(last + (taken + 1) * period, end + 1, period):
            host.now_us = t
            self._step(t - period, t)
        host.now_us = max(now_before, end)
        self.last_us = end

    def _rest_holds(self) -> bool:
        host = self._host
        apad, dt_s = host.apad, self.task.period_us / US_PER_S
        if not rest_holds(apad, host.mussels, apad.current_mps, dt_s):
            return False
        rest = apad.rest
        if isinstance(rest, BOUNDED):
            return rest.limit > rest.steps and self._may_park()
        return not _busy(apad)

    def _may_park(self) -> bool:
        """Whether a closed form may run parked: the failsafe cannot act on it (it acts on a busy primitive,
        and only once a GCS heard has gone silent; an ideal link's GCS sends no heartbeat)."""
        apad = self._host.apad
        return not (_busy(apad) and apad.params.fs_gcs_enable and self._host.modes.last_gcs_heartbeat_us is not None)

    def stop(self) -> None:
        """The vehicle closes: the ticks up to now taken, no more."""
        self.settle()
        self._host.apad.pending = None
        self.parked = False
        self.task.active = False

    def _rearm(self) -> None:
        assert self.last_us is not None
        self._scheduler.reschedule(self.task, next_us=self.last_us + self.task.period_us, active=True)
        self._unpark()

    def _unpark(self) -> None:
        self.parked = False
        self._host.apad.pending = None
        if self.on_rearm is not None:
            self.on_rearm()

    def ahead(self) -> RestAhead | None:
        """What the parked rest holds ahead of now (the ticks until now taken); None while ticking."""
        self.catch_up()
        apad = self._host.apad
        rest = apad.rest
        if not self.parked or rest is None or isinstance(rest, BOUNDED):  # busy: the streams at their period
            return None
        if isinstance(rest, ChargingRest) and not rest.closed:  # known only to come to full, step by step
            return RestAhead(replace(rest.state(), battery_v=BATTERY_FULL_V), None, self.last_us or 0, 0, 0, None)
        assert self.last_us is not None
        still = rest.still_from()
        period = self.task.period_us
        end = rest.after(max(still, rest.steps))
        still_us = self.last_us + max(0, still - rest.steps) * period
        return RestAhead(end, still_us, self.last_us, rest.steps, period, rest)


@dataclass(frozen=True)
class RestAhead:
    """A parked hull's rest from `last_us` (its last tick taken, `steps` into the rest) on.

    `end` is the hull once the rest has done all it can (drained flat, charged full, or as now); it
    gets there at `still_us`, or at an instant with no closed form (None: a charging rest in lockstep,
    whose battery rises step by step, `rest.ChargingRest`). `hull_at` is the hull at an instant ahead,
    in the closed form (`rest.Rest.after`) the ticks would leave; only where `still_us` is known.
    """

    end: VehicleState
    still_us: int | None
    last_us: int
    steps: int
    period_us: int
    rest: Rest | ChargingRest | None

    def hull_at(self, t_us: int) -> VehicleState:
        """The hull after the ticks up to `t_us` (every tick at or before it: read after the physics task's
        turn in that instant, as a stream task reads it)."""
        if self.rest is None or self.still_us is None or t_us >= self.still_us:
            return self.end
        return self.rest.after(self.steps + max(0, t_us - self.last_us) // self.period_us)


def _busy(apad: ApadState) -> bool:
    """A primitive under way: the failsafe may act on it at any tick (`Modes.check_failsafe`)."""
    p = apad.primitive
    return p.kind != Primitive.HOLD and p.progress == Progress.IN_PROGRESS
