"""The idle wait's wake time as it was before the fleet-wide belief, one aMussel at a time through the scalar reads
(`battery`, `drain_per_s`): the reference `gcs.loop.wake_times.pool_look_by` answers to, to the bit."""

from __future__ import annotations

from gcs.belief.real_fleet import MAX_REPORT_AGE_S
from gcs.loop.fleet_knowledge import FleetKnowledge
from gcs.loop.wake_times import STEP_SLACK_S
from gcs.swarm.shares import CLAIM_GRACE_S
from missiontime import US_PER_S
from mussel_sim.vocabulary import MusselState


def scalar_pool_look_by(knows: FleetKnowledge) -> float | None:
    """`pool_look_by` as it was (a knowledge that hears acoustically is read through its `api`)."""
    now_s = knows.clock.time()
    threshold = knows.settings.mission.pool_threshold
    times = []
    for m in knows.in_states((MusselState.ACTIVE,)):
        drain = knows.drain_per_s(m)
        battery = knows.battery(m)
        if drain > 0 and battery >= threshold:
            times.append(now_s + (battery - threshold) / drain - STEP_SLACK_S)
        if knows.acoustic is not None and knows.simulated(m):
            heard_s = knows.api.mussels[m].time_us / US_PER_S
            times.append(heard_s + MAX_REPORT_AGE_S)
            if drain > 0 and battery > 0:
                times.append(now_s + battery / drain - STEP_SLACK_S)
    if knows.shares is not None:
        times += [lost_us / US_PER_S + CLAIM_GRACE_S for lost_us in knows.shares.lost_since_us.values()]
    ahead = [t for t in times if t >= now_s - STEP_SLACK_S]
    return min(ahead) if ahead else None


def same_instant(got: float | None, want: float | None) -> bool:
    """Both None, or the same float to the bit."""
    return (got is None and want is None) or (got is not None and want is not None and got.hex() == want.hex())
