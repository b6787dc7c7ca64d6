"""The energy-sharing loop of one aPad (the paper's Fig. 7), composed of parts written on the aPad API.

    FleetKnowledge  what the loop knows of the fleet: reads only (gcs.loop.fleet_knowledge)
    LoopBook        what it writes down: claims, homes, sleep orders sent (gcs.loop.book)
    ApadActions     the aPad's commands with their waits (gcs.loop.actions)
    phases          idle wait, plan and run a collection, charging wait, plan and run a
                    redeployment, recover after a crash (gcs.loop.phases)
    turns           the loop's shapes, rounds or rolling, picked by the strategy (gcs.loop.turns)

The loop itself only recovers after a resume and repeats its turn. It commands the aPad exactly as
a field script would, waiting with `clock.sleep`, so the same code runs in lockstep and in the
field. The operator (console or script) controls it through `LoopControl`: pause, stop, strategy
switch. The mission ends on mission time, on the aPad battery threshold, or on an operator stop;
it never ends mid-dock.
"""

from __future__ import annotations

from gcs.acoustic_net.network import AcousticNetwork
from gcs.belief.real_fleet import RealFleet
from gcs.link.apad_api import ApadApi, Location
from gcs.loop.actions import ApadActions
from gcs.loop.book import LoopBook
from gcs.loop.control import EndReason, LoopControl, LoopLog, LoopSettings, LoopStatus, MissionEnded, Phase
from gcs.loop.crew import Crew
from gcs.loop.fleet_knowledge import FleetKnowledge
from gcs.loop.phases import recover
from gcs.loop.turns import turn_for
from gcs.records.events import EventLog
from gcs.swarm.shares import FleetShares
from missiontime import Clock

__all__ = ["EndReason", "EnergySharingLoop", "LoopControl", "LoopSettings", "MissionEnded", "Phase"]


class EnergySharingLoop:
    """One aPad's loop: its parts, built once; `run` to the mission's end."""

    def __init__(
        self,
        api: ApadApi,
        clock: Clock,
        settings: LoopSettings,
        homes: dict[int, Location],
        apad_id: int,
        events: EventLog | None = None,
        control: LoopControl | None = None,
        shares: FleetShares | None = None,
        real: RealFleet | None = None,
        status: LoopStatus | None = None,
        acoustic: AcousticNetwork | None = None,
    ) -> None:
        """`shares`: with several aPads, the one record of who serves which aMussel
        (`gcs.swarm.shares`); this loop then plans, calls up and fetches only within its aPad's
        share, and its events name the aPad. `status`: a resumed mission's, from its checkpoint."""
        self.apad_id = apad_id
        self.control = control or LoopControl()
        self.status = status or LoopStatus(strategy=settings.mission.collect_strategy)
        log = LoopLog(events or EventLog(), clock, apad_id if shares is not None else None)
        self.knows = FleetKnowledge(api, clock, settings, homes, apad_id, shares, real, acoustic, self.status.orders)
        self.book = LoopBook(self.knows, self.status.orders, log)
        self.act = ApadActions(self.knows, self.control, self.status, log)
        self.crew = Crew(self.knows, self.book, self.act, self.status, self.control, log)

    @property
    def api(self) -> ApadApi:
        return self.knows.api

    @property
    def homes(self) -> dict[int, Location]:
        return self.knows.homes

    def run(self, resume: bool = False) -> EndReason:
        """Run until the mission ends; the aPad is left holding, never mid-dock.

        `resume`: continue a mission whose GCS crashed (status restored from a checkpoint): first
        settle what the crash interrupted, from what the aPad and the fleet report now.
        """
        crew, status = self.crew, self.status
        crew.log("mission_resume" if resume else "mission_start", strategy=status.strategy)
        try:
            if resume:
                recover(crew)
            while True:
                turn_for(status.strategy)(crew)
        except MissionEnded as ended:
            status.end_reason = ended.reason
        self.act.set_phase(Phase.ENDED)
        self.act.finish()
        assert status.end_reason is not None
        crew.log("mission_end", reason=str(status.end_reason), cost_m=round(status.cost_m, 3))
        return status.end_reason
