"""Real aMussels beside simulated ones: what the GCS believes between their sparse reports.

A real agent reports now and then (AMUSSEL_STATUS with `simulated = 0`, on the bridge address).
Between reports the GCS keeps an estimate: the battery by the fleet's own models from the last
report (eq. 1 discharging, at the drain of its duty: its profile or the last sleep order sent to it;
eq. 2 charging while it is on one of our slots, which we know from the aPad whatever the agent
last said), the position at the last fix (the random drift has zero mean; an active aMussel sits on
the seabed). Every estimate carries its age, and nothing shows it as
more than that. One silent for longer than MAX_REPORT_AGE_S is not planned for: the aPad would go
to a unit that may be dead. Simulated aMussels report at least every keep-alive window (5 s) and are run forward in the
model's steps between (`gcs.belief.foresight`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from gcs.acoustic_net.knowledge import run_down_start
from gcs.link.fleet_table import MusselTable
from mussel_sim.battery import ChargeProfile, DischargeProfile, step_battery
from mussel_sim.vocabulary import MusselState

MAX_REPORT_AGE_S = 600.0  # mission seconds; older, a real aMussel is left out of the plans


@dataclass(frozen=True)
class Estimate:
    mussel_id: int
    battery_frac: float  # estimated now
    reported_battery_frac: float  # as last reported
    age_s: float  # mission seconds since that report


class RealFleet:
    """Estimates for the real aMussels in `table` (those not simulated), from the report times the
    registry keeps (`VehicleRegistry.mussel_heard_us`)."""

    def __init__(
        self, table: MusselTable, heard_us: dict[int, int], discharge: DischargeProfile, charge: ChargeProfile,
        theta: float,
    ) -> None:
        self.table, self.heard_us, self.theta = table, heard_us, theta
        self.discharge, self.charge = discharge, charge

    def ids(self) -> list[int]:
        return sorted(m for m in self.heard_us if m in self.table and not self.table[m].simulated)

    def estimate(self, mussel_id: int, now_us: int, on_slot: bool = False,
                 drain_per_min: float | None = None, anchor: tuple[int, float] | None = None) -> Estimate:
        """Its battery now by the models; `on_slot`: the aPad reports it latched on one of its slots;
        `drain_per_min`: what its duty uses deployed (None: the scenario's discharge profile); `anchor`:
        (mission us, battery) estimated when its duty last changed (a sleep order): after its report,
        the discharge at the new duty runs from there (`run_down_start`)."""
        view = self.table[mussel_id]
        heard_us = self.heard_us[mussel_id]
        age_s = max(now_us - heard_us, 0) / 1e6
        charging = on_slot or view.state == MusselState.DOCKED
        if view.state == MusselState.DEPLETED and not charging:
            battery = view.battery_frac
        else:  # eqs. (1)-(2) over the time since the report, in one step (charge: the band it was in)
            start_us, start_frac = run_down_start(heard_us, view.battery_frac, None if charging else anchor)
            run_s = max(now_us - start_us, 0) / 1e6
            discharge = self.discharge if drain_per_min is None else DischargeProfile("duty", drain_per_min)
            battery = float(step_battery(np.array([start_frac]), np.array([charging]), discharge,
                                         self.charge, self.theta, run_s)[0])
        return Estimate(mussel_id, battery, view.battery_frac, age_s)

    def below(self, threshold: float, now_us: int, drain_per_min: Callable[[int], float] | None = None,
              anchor: Callable[[int], tuple[int, float] | None] | None = None) -> list[int]:
        """Real aMussels active by their last report, heard within MAX_REPORT_AGE_S, whose estimated
        battery is below `threshold`; `drain_per_min`, `anchor`: each one's, as `estimate` takes them."""
        out = []
        for m in self.ids():
            if self.table[m].state != MusselState.ACTIVE:
                continue
            e = self.estimate(m, now_us, drain_per_min=None if drain_per_min is None else drain_per_min(m),
                              anchor=None if anchor is None else anchor(m))
            if e.age_s <= MAX_REPORT_AGE_S and e.battery_frac < threshold:
                out.append(m)
        return out
