"""What the loop tells a strategy, and the loop of the rolling policy (`Traits` of a strategy).

`outlook` gives a planning step the mission time left and the battery model. `charged` is when a
docked aMussel may go back: at the scenario's charged threshold, or, for a strategy that releases
early, once it holds enough to stay active to the mission end. `rolling_round` is one turn of the
rolling policy: wait for work, put back every aMussel that is charged, fill the free slots at once.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from gcs.mission.control import LoopSettings, Phase
from gcs.mission.strategies import Outlook, traits
from mussel_sim.battery import charge_profile, discharge_profile, sim_minutes

if TYPE_CHECKING:
    from gcs.mission.loop import EnergySharingLoop

DOCK_S = 20.0  # besides surfacing, at each collection stop: closing in and latching
RELEASE_MARGIN_S = 60.0  # released early, an aMussel still has this much charge left at the end
LOOK_S = 5.0  # the rolling wait plans again this often for a free slot


def outlook(settings: LoopSettings, now_s: float) -> Outlook:
    mission = settings.mission
    return Outlook(
        time_left_s=max(mission.duration_s - now_s, 0.0),
        drain_per_s=discharge_profile(settings.mussel_discharge).rate_per_min * sim_minutes(mission.theta, 1.0),
        charge=charge_profile(settings.mussel_charge),
        theta=mission.theta,
        speed_mps=settings.apad_speed_mps,
        stop_s=settings.mussel_surfacing_s + DOCK_S,
        charged_frac=mission.charged_threshold,
    )


def charged(loop: EnergySharingLoop, mussel_id: int) -> bool:
    """Whether a docked aMussel may go back now."""
    battery = loop._battery(mussel_id)
    if battery >= loop.settings.mission.charged_threshold:
        return True
    if not traits(loop.status.strategy).release_early:
        return False
    view = outlook(loop.settings, loop.clock.time())
    return battery >= view.drain_per_s * (view.time_left_s + RELEASE_MARGIN_S)


def rolling_round(loop: EnergySharingLoop) -> None:
    """Wait until an aMussel on board is charged or a free slot has a candidate the strategy takes;
    put back the charged ones (nearest first), then fetch what the strategy plans for the free slots."""
    loop._set_phase(Phase.IDLE_WAIT)
    loop._command(loop.api.hold)
    next_look_s = 0.0

    def work() -> bool:
        nonlocal next_look_s
        if any(charged(loop, m) for m in loop._docked().values()):
            return True
        if loop.clock.time() < next_look_s or not loop._free_slots() or loop._too_late_to_call_up():
            return False
        next_look_s = loop.clock.time() + LOOK_S
        return bool(loop._link_up() and (loop._orphans() or loop._collection_route()))

    loop._wait_until(work)
    done = {m for m in loop._docked().values() if charged(loop, m)}
    if done:
        loop._redeploy(loop._plan_redeployment(only=done))
        loop.status.cycles += 1
    if loop._free_slots() and not loop._too_late_to_call_up():
        route = loop._plan_collection()
        if route:
            loop._collect(route)
