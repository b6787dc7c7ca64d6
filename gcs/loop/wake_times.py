"""When time alone could turn a wait of the loop true: the waits' declarations (`ApadActions.wait_until`'s
`look_by`), read from what the loop knows.

A wait's condition reads what the GCS has heard and the mission time. News (a report, an acknowledgement, a
re-share: `FleetKnowledge.news`) can change it at any moment; between news only time does, through the beliefs that run
between reports (`gcs.belief`): a deployed aMussel's battery running down to the pool threshold, a docked
one's charging up to its release, an acoustic report growing too old, a lost aPad's claims running out.
Each function gives a lower bound of the first such instant (never later than the truth: a platform that
wakes there looks once more at worst); None where only news can. The beliefs move in whole model steps, so
each bound gives one step of slack.
"""

from __future__ import annotations

import numpy as np

from gcs.belief.real_fleet import MAX_REPORT_AGE_S
from gcs.loop.fleet_knowledge import RELEASE_MARGIN_S, FleetKnowledge
from gcs.strategies import traits
from gcs.swarm.shares import CLAIM_GRACE_S
from missiontime import US_PER_S
from mussel_sim.battery import sim_minutes
from mussel_sim.vocabulary import MusselState

STEP_SLACK_S = 1.0  # a belief runs forward in whole model steps (1 s): a bound this much early is safe


def earliest(times: list[float]) -> float | None:
    return min(times) if times else None


def pool_look_by(knows: FleetKnowledge) -> float | None:
    """The first instant the charging pool, or what a collection waits for, could grow by time alone: an
    active aMussel's believed battery reaching the pool threshold, one heard now and then falling silent
    too long or believed empty (fewer on the seabed to wait for), a lost aPad's claims lapsing. Over the
    whole fleet's beliefs at once (`FleetKnowledge.believed`), each instant as the scalar formulas give it."""
    now_s = knows.clock.time()
    threshold = knows.settings.mission.pool_threshold
    b = knows.believed((MusselState.ACTIVE,))
    draining = b.drain_per_s > 0
    reaching = draining & (b.battery >= threshold)
    times = [now_s + (b.battery[reaching] - threshold) / b.drain_per_s[reaching] - STEP_SLACK_S]
    if knows.acoustic is not None:
        times.append(b.heard_us[b.simulated] / US_PER_S + MAX_REPORT_AGE_S)
        emptying = b.simulated & draining & (b.battery > 0)  # believed empty already: time changes nothing more
        times.append(now_s + b.battery[emptying] / b.drain_per_s[emptying] - STEP_SLACK_S)
    if knows.shares is not None:
        times.append(np.array([lost_us / US_PER_S + CLAIM_GRACE_S for lost_us in knows.shares.lost_since_us.values()],
                              np.float64))
    every = np.concatenate(times)
    ahead = every[every >= now_s - STEP_SLACK_S]
    return float(ahead.min()) if ahead.size else None


def charged_look_by(knows: FleetKnowledge, mussel_id: int, strategy: str) -> float | None:
    """The first instant a docked aMussel could be charged enough to go back (`FleetKnowledge.charged`),
    charging at its profile's fastest rate throughout; None if it is already."""
    if knows.charged(mussel_id, strategy):
        return None
    mission = knows.settings.mission
    now_s, battery = knows.clock.time(), knows.battery(mussel_id)
    fastest = max(knows.charge(mussel_id).rates_per_min) * sim_minutes(mission.theta, 1.0)  # per mission second
    ahead = battery + fastest * STEP_SLACK_S  # the most a belief in whole steps can be behind
    at = now_s + (mission.charged_threshold - ahead) / fastest
    if traits(strategy).release_early:  # enough for the time left: the need falls as the charge rises
        drain = knows.drain_per_s(mussel_id)
        need_s = mission.duration_s + RELEASE_MARGIN_S
        at = min(at, (drain * need_s - ahead + fastest * now_s) / (fastest + drain))
    return max(at, now_s)


def all_charged_look_by(knows: FleetKnowledge, ids: list[int], strategy: str) -> float | None:
    """When every one of `ids` could be charged (the last of them)."""
    times = [t for m in ids if (t := charged_look_by(knows, m, strategy)) is not None]
    return max(times) if times else None


def any_charged_look_by(knows: FleetKnowledge, ids: list[int], strategy: str) -> float | None:
    """When the first of `ids` could be charged."""
    return earliest([t for m in ids if (t := charged_look_by(knows, m, strategy)) is not None])

