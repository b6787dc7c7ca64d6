"""What the GCS knows each aMussel does while deployed: its drain and its wake schedule (`Duty`).

A simulated aMussel starts on its scenario profile (fleet.profile, [fleet.profiles]); a sleep order the
GCS sends (`ApadApi.sleep_order`) replaces it with the order's duty-cycle model
(`mussel_sim.behaviour.duty_cycle_rate_per_min`), as the fleet applies it. The planner reads each
aMussel's own drain and the mission time it can next hear a call-up (`mussel_sim.wake.next_wake_s`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from gcs.scenario.model_params import fleet_params
from gcs.scenario.reader import Scenario
from mussel_sim.battery import ChargeProfile, sim_minutes
from mussel_sim.behaviour import BehaviourProfile, duty_cycle_rate_per_min
from mussel_sim.wake import next_wake_s


@dataclass(frozen=True)
class Duty:
    """rate_per_min: battery fraction used per simulated minute while deployed; interval_s, awake_s: the
    wake schedule in the aMussel's own seconds (interval 0: always on); ordered: set by a sleep order;
    charge: its charge profile on a slot (None: the loop's default, `LoopSettings.mussel_charge`; a sleep
    order keeps the aMussel's own)."""

    rate_per_min: float
    interval_s: float = 0.0
    awake_s: float = 0.0
    ordered: bool = False
    charge: ChargeProfile | None = None

    @classmethod
    def of_profile(cls, profile: BehaviourProfile) -> Duty:
        return cls(profile.discharge.rate_per_min, profile.wake_interval_s or 0.0, profile.awake_s or 0.0,
                   charge=profile.charge)

    @classmethod
    def of_order(cls, interval_s: float, awake_s: float) -> Duty:
        """The fleet's model of a sleep order (interval 0: always on at duty 1)."""
        return cls(duty_cycle_rate_per_min(interval_s, awake_s), interval_s, awake_s if interval_s else 0.0, True)

    @property
    def asleep(self) -> bool:
        """On a wake schedule (it hears a call-up only while awake)."""
        return self.interval_s > 0

    def drain_per_s(self, theta: float) -> float:
        """Battery fraction per mission second while deployed."""
        return self.rate_per_min * sim_minutes(theta, 1.0)

    def wake_in_s(self, mussel_id: int, t_s: float, theta: float) -> float:
        """Mission seconds from `t_s` until it next hears a call-up (0: awake now, or always on)."""
        return next_wake_s(mussel_id, self.interval_s or None, self.awake_s, t_s, theta) - t_s

    def longest_wait_s(self, theta: float) -> float:
        """The longest a call-up may wait for its wake, mission seconds (0: always on)."""
        return self.interval_s / theta


@dataclass
class OrdersSent:
    """What one loop's sleep orders changed: each ordered aMussel's duty since (over its scenario
    profile), and for one heard only now and then (acoustically, or a real aMussel) the mission time and
    the battery believed when its duty changed, from which its run-down goes on. Part of the loop's
    status, so a checkpoint keeps it and a restored mission plans on the orders sent before the crash."""

    duties: dict[int, Duty] = field(default_factory=dict)
    changed: dict[int, tuple[int, float]] = field(default_factory=dict)
    sent: int = 0  # orders sent so far: a belief cached on the duties is made again when it grows


def scenario_duties(scenario: Scenario, ids: list[int]) -> dict[int, Duty]:
    """Each of `ids` (the simulated aMussels) on its scenario profile: fleet.profile, or the profile
    [fleet.profiles] lists it under, with the scenario's battery models."""
    table = fleet_params(scenario).profile_table
    named = {m: name for name, members in scenario.fleet.profiles for m in members}
    return {m: Duty.of_profile(table.profiles[table.index(named.get(m, scenario.fleet.profile))]) for m in ids}
