"""Real aMussels beside simulated ones: what the GCS believes between their sparse reports.

A real agent reports now and then (AMUSSEL_STATUS with `simulated = 0`, on the bridge address).
Between reports the GCS keeps an estimate: the battery by the fleet's own discharge model (eq. 1,
the scenario's profile and theta) from the last report, the position at the last fix (the random
drift has zero mean; an active aMussel sits on the seabed). Every estimate carries its age, and
nothing shows it as more than that. Simulated aMussels report every second and need none.
"""

from __future__ import annotations

from dataclasses import dataclass

from gcs.link.fleet_table import MusselTable
from mussel_sim.battery import DischargeProfile, sim_minutes
from mussel_sim.vocabulary import MusselState


@dataclass(frozen=True)
class Estimate:
    mussel_id: int
    battery_frac: float  # estimated now
    reported_battery_frac: float  # as last reported
    age_s: float  # mission seconds since that report


class RealFleet:
    """Estimates for the real aMussels in `table` (those not simulated), from the report times the
    registry keeps (`VehicleRegistry.mussel_heard_us`)."""

    def __init__(self, table: MusselTable, heard_us: dict[int, int], discharge: DischargeProfile, theta: float) -> None:
        self.table, self.heard_us, self.discharge, self.theta = table, heard_us, discharge, theta

    def ids(self) -> list[int]:
        return sorted(m for m in self.heard_us if m in self.table and not self.table[m].simulated)

    def estimate(self, mussel_id: int, now_us: int) -> Estimate:
        view = self.table[mussel_id]
        age_s = max(now_us - self.heard_us[mussel_id], 0) / 1e6
        battery = view.battery_frac
        if view.state in (MusselState.ACTIVE, MusselState.SURFACING, MusselState.FLOATING, MusselState.SINKING):
            battery = max(0.0, battery - self.discharge.rate_per_min * sim_minutes(self.theta, age_s))
        return Estimate(mussel_id, battery, view.battery_frac, age_s)

    def below(self, threshold: float, now_us: int) -> list[int]:
        """Real aMussels active by their last report whose estimated battery is below `threshold`."""
        return [m for m in self.ids()
                if self.table[m].state == MusselState.ACTIVE and self.estimate(m, now_us).battery_frac < threshold]
