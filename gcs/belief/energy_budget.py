"""Whether the aPad's battery covers a trip: the planner never starts one it cannot finish.

The GCS's model of the aPad's energy is the SITL's (apad_sitl/energy.py, docs/long_term.md): a
battery of `capacity_wh` over 10.5..16 V, linear in voltage; a hotel load; thrust at cruise; and
what charging aMussels draws through the inductive link. A trip is a collection, the charging
wait and the redeployment (a round), then the way home; it is affordable if the battery, less the
trip, keeps `reserve_frac` of the capacity. Pure: numbers in, numbers out.
"""

from __future__ import annotations

from dataclasses import dataclass

from apad_sitl.params import ApadParams
from apad_sitl.vehicle import BATTERY_EMPTY_V, VOLT_RANGE

THRUST_MARGIN = 1.5  # cruise thrust only: accelerating, holding against drift and docking cost more


@dataclass(frozen=True)
class EnergyBudget:
    capacity_wh: float
    hotel_w: float  # the hotel load: computer, Kinect, radios
    cruise_wh_per_m: float  # thrust at cruise speed, per metre, with THRUST_MARGIN
    mussel_battery_wh: float  # an aMussel battery over its 0..1
    charge_efficiency: float  # aPad to aMussel, through the inductive link
    reserve_frac: float = 0.15  # never planned away: currents, re-sent Go Tos, a model that is wrong
    charged_frac: float = 0.95  # at home, charge at least to this before setting out again

    @classmethod
    def of(cls, p: ApadParams, speed_mps: float, reserve_frac: float = 0.15) -> EnergyBudget:
        """The budget of an aPad with these parameters cruising at `speed_mps`."""
        watts_per_vph = p.batt_capacity_wh / VOLT_RANGE  # 1 V/h of drain is this many watts
        thrust = p.drag_per_s * speed_mps  # steady cruise: thrust balances drag
        cruise_w = p.batt_drain_thrust_vph * thrust * thrust * watts_per_vph
        return cls(p.batt_capacity_wh, p.batt_drain_idle_vph * watts_per_vph,
                   THRUST_MARGIN * cruise_w / speed_mps / 3600.0, p.mussel_battery_wh, p.charge_efficiency,
                   reserve_frac)

    def battery_wh(self, battery_v: float) -> float:
        """Energy left in the battery at `battery_v`."""
        return max(0.0, min(1.0, (battery_v - BATTERY_EMPTY_V) / VOLT_RANGE)) * self.capacity_wh

    def trip_wh(self, metres: float, seconds: float, charge_frac: float = 0.0) -> float:
        """A trip of `metres` under way, `seconds` long, passing `charge_frac` aMussel batteries (summed)."""
        return (self.cruise_wh_per_m * metres + self.hotel_w * seconds / 3600.0
                + charge_frac * self.mussel_battery_wh / self.charge_efficiency)

    def affords(self, battery_v: float, trip_wh: float) -> bool:
        """Whether the battery covers `trip_wh` and keeps the reserve."""
        return self.battery_wh(battery_v) - trip_wh >= self.reserve_frac * self.capacity_wh

    def charged(self, battery_v: float) -> bool:
        return self.battery_wh(battery_v) >= self.charged_frac * self.capacity_wh
