"""Where a run's time went: each aMussel's time per state, each aPad's time travelling, docking, holding.

The aMussels' side is counted by the fleet's recorder (`mussel_sim.state_time`); this module turns it
into result fields and arrays. The aPads' side is counted here, at the fleet's step rate, from what
the GCS hears of each aPad's primitive (`PRIMITIVE_STATUS`): travelling while a Go To is in
progress, docking while a Dock or Undock is (approach, latch, release), holding otherwise (Hold
between legs, waiting for an aMussel to surface, charging, idle). `add_step` is pure; `track`
registers it on the world's clock, ending with the fleet's last step, so an aPad's times add up
exactly to the mission time. On the event platform (an `EventClock`) the same count is taken when
time moves on, over the stretch since, by the primitive heard all along it (it changes only at instants).
"""

from __future__ import annotations

from enum import StrEnum
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from apad_sitl.vocabulary import Primitive, Progress
from gcs.link.telemetry import PrimitiveView
from missiontime import US_PER_S, seconds_to_us
from missiontime.event_clock import EventClock
from mussel_sim.recorder import Recorder
from mussel_sim.state_time import NEVER

if TYPE_CHECKING:
    from gcs.mission.world import World

ApadTimes = dict[str, int]  # ApadActivity -> mission microseconds


class ApadActivity(StrEnum):
    TRAVELLING = "travelling"
    DOCKING = "docking"
    HOLDING = "holding"


ACTIVITIES = tuple(ApadActivity)


def activity_of(primitive: PrimitiveView) -> ApadActivity:
    """What an aPad is doing, by the primitive it last reported."""
    if primitive.progress == Progress.IN_PROGRESS:
        if primitive.primitive == Primitive.GOTO:
            return ApadActivity.TRAVELLING
        if primitive.primitive in (Primitive.DOCK, Primitive.UNDOCK):
            return ApadActivity.DOCKING
    return ApadActivity.HOLDING


def add_step(times: ApadTimes, primitive: PrimitiveView, dt_us: int) -> None:
    """Count one step of `dt_us` by what the aPad reported at its end (as the fleet counts its steps)."""
    key = str(activity_of(primitive))
    times[key] = times.get(key, 0) + dt_us


def apad_shares(times: ApadTimes) -> dict[str, float]:
    """{travelling_share, docking_share, holding_share}: fractions of the time counted, summing to 1."""
    total = sum(times.values())
    return {f"{a}_share": round(times.get(a, 0) / total, 4) if total else 0.0 for a in ACTIVITIES}


def track(world: World, times: dict[int, ApadTimes]) -> None:
    """Count every aPad of `times` (system id -> its times, filled in place) at the fleet's steps,
    from now to the fleet's last step (`FleetRunner.end_us`)."""
    clock, fleet = world.clock, world.fleet
    period_us = seconds_to_us(fleet.config.step_period_s)
    last = [clock.now_us]

    def count(upto_us: int) -> None:
        dt_us, last[0] = upto_us - last[0], upto_us
        for sysid, acc in times.items():
            view = world.link.vehicles.get(sysid)
            add_step(acc, view.primitive if view is not None else PrimitiveView(), dt_us)

    def sample(now_us: int) -> None:
        if now_us <= last[0] or (fleet.end_us is not None and now_us > fleet.end_us):
            return
        count(now_us)

    def stretch(now_us: int) -> None:  # event platform: the stretch since the last move, to the fleet's end
        upto = now_us if fleet.end_us is None else min(now_us, fleet.end_us)
        if upto > last[0]:
            count(upto)

    if isinstance(clock, EventClock):
        clock.on_time(stretch)
    else:
        clock.scheduler.every(fleet.config.step_period_s, sample, "apad-time", clock.now_us + period_us)


def mussel_times(rec: Recorder) -> tuple[list[dict[str, float]], list[float | None]]:
    """Per aMussel (the recorder's id order): {state: seconds} and the mission second it first depleted."""
    seconds = rec.times.seconds()
    states = [{name: round(float(s[k]), 3) for name, s in seconds.items()} for k in range(rec.ids.size)]
    first = [None if us == NEVER else round(us / US_PER_S, 3) for us in rec.times.first_depleted_us.tolist()]
    return states, first


def trace_arrays(rec: Recorder, apads: dict[int, ApadTimes]) -> dict[str, NDArray[Any]]:
    """The same as arrays for traces.npz: state_s `(n, 6)` with state_names, first_depleted_s `(n,)`
    (NaN: never), apad_ids `(m,)`, apad_activity_s `(m, 3)` with apad_activities."""
    ids = sorted(apads)
    seconds = rec.times.seconds()
    return {
        "state_names": np.array(list(seconds)),
        "state_s": np.stack(list(seconds.values()), axis=1),
        "first_depleted_s": rec.times.first_depleted_s(),
        "apad_ids": np.array(ids, np.int64),
        "apad_activities": np.array([str(a) for a in ACTIVITIES]),
        "apad_activity_s": np.array([[apads[i].get(a, 0) / US_PER_S for a in ACTIVITIES] for i in ids],
                                    np.float64).reshape(len(ids), len(ACTIVITIES)),
    }
