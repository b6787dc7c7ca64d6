"""What a phase of the loop works with (`Crew`): the phases (`gcs.loop.phases`), the trip to the
home charger (`gcs.loop.home_charge`) and the loop's shapes (`gcs.loop.turns`) all take one."""

from __future__ import annotations

from dataclasses import dataclass

from gcs.loop.actions import ApadActions
from gcs.loop.book import LoopBook
from gcs.loop.control import LoopControl, LoopLog, LoopSettings, LoopStatus
from gcs.loop.fleet_knowledge import FleetKnowledge
from gcs.strategies import CostWeights


@dataclass(frozen=True)
class Crew:
    """What a phase works with: the fleet as known (reads), what the loop writes down, the aPad's actions,
    the status, the operator's controls, the loop's event log."""

    knows: FleetKnowledge
    book: LoopBook
    act: ApadActions
    status: LoopStatus
    control: LoopControl
    log: LoopLog

    @property
    def settings(self) -> LoopSettings:
        return self.knows.settings

    @property
    def weights(self) -> CostWeights:
        mission = self.settings.mission
        return CostWeights(mission.distance_scale, mission.energy_scale)
