"""The aPad as the swarm's energy hub: what charging aMussels draws from its battery, and the home
charging station ("it can return to a home position and be charged while deployed thanks to a
waterproof charging jack on its hull", the paper, section II).

The model (assumptions; the numbers are `ApadParams`, docs/long_term.md says why each):

- The battery holds `batt_capacity_wh` between 10.5 V and 16.0 V, linear in voltage, as the drain
  model of `vehicle.py` already treats it (its 0.5 V/h hotel load is then 36 W at 400 Wh: an
  on-board PC, a Kinect, a router).
- An aMussel's battery holds `mussel_battery_wh` over its normalised range 0..1. What a docked
  aMussel gains is drawn from the aPad through the inductive link at `charge_efficiency`. The aPad
  learns the gain from the aMussel's own reports (AMUSSEL_STATUS.battery) while it is latched in one
  of its slots, so the energy passed is the aMussel model's, whatever its time scale (theta).
- At home (within `home_radius_m` of its home, slower than HOME_STILL_MPS) the jack charges the
  battery at `home_charge_w` until full; BATTERY_STATUS says CHARGING meanwhile.
- A latched aMussel's gain is what it reports above the most it reported since it latched (a
  high-water mark): charging only ever rises, so its own reports pass exactly their rises, and a
  hostile run of made-up reports swinging between empty and full passes at most one battery a latch.

Pure bookkeeping over the aPad's state: the core feeds it the statuses it hears and calls `step`
with each physics step's `dt_s`.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable
from dataclasses import replace

from apad_sitl.energy_counters import EnergyCounters
from apad_sitl.home_charger import could_charge, home_charge_wh, volts_after
from apad_sitl.host import invalid_reason
from apad_sitl.state import ApadState
from apad_sitl.vehicle import BATTERY_FULL_V
from apad_sitl.vocabulary import Latch

_ON_SLOT = (Latch.LATCHED, Latch.RELEASING)


class EnergyMeter:
    """The aPad's energy part: aMussels' gains drawn from its battery, and home charging."""

    def __init__(self, apad: ApadState, dropped: Counter[str] | None = None) -> None:
        """`dropped`: the vehicle's drop counter (a latched aMussel's battery out of 0..1 is counted there)."""
        self.apad = apad
        self.dropped: Counter[str] = dropped if dropped is not None else Counter()
        self._high: dict[int, float] = {}  # latched aMussel -> the most it reported since it latched
        self._source: dict[int, int] = {}  # latched aMussel -> the system that reports it (the first heard)

    @property
    def counters(self) -> EnergyCounters:
        return self.apad.energy

    @property
    def listening(self) -> bool:
        """Whether an aMussel is latched here (a batch of statuses is only read for it then)."""
        return bool(self._latched() or self._high)

    def heard(self, reports: Iterable[tuple[int, float, int]]) -> None:
        """(aMussel id, battery 0..1, sending system) as heard: a rise of one latched here above the
        most it reported since it latched is drawn from the battery. Only the system that first
        reported it since it latched is believed, and only its new highs: a stranger's reports
        swinging between empty and full would otherwise drain the battery (a spoof)."""
        latched = self._latched()
        for mussel_id in [m for m in self._high if m not in latched]:
            del self._high[mussel_id]  # released: its next docking starts afresh
            self._source.pop(mussel_id, None)
        if not latched:
            return
        p = self.apad.params
        drawn = 0.0
        for mussel_id, battery, source in reports:
            if mussel_id not in latched:
                continue
            if not 0.0 <= battery <= 1.0:  # NaN fails too: the high-water bound holds for a battery only
                self.dropped[invalid_reason("AMUSSEL_STATUS", "battery")] += 1
                continue
            if self._source.setdefault(mussel_id, source) != source:
                continue
            high = self._high.get(mussel_id)
            self._high[mussel_id] = battery if high is None else max(high, battery)
            if high is not None and battery > high:
                gained_wh = (battery - high) * p.mussel_battery_wh
                self.apad.energy.passed_wh += gained_wh
                drawn += gained_wh / p.charge_efficiency
        if drawn:
            self.apad.energy.drawn_wh += drawn
            self._set_volts(volts_after(self.apad.state.battery_v, -drawn, p))

    def step(self, dt_s: float) -> float:
        """Home charging over the last `dt_s` seconds; returns the Wh it charged."""
        state, p = self.apad.state, self.apad.params
        charging = could_charge(state, p) and state.battery_v < BATTERY_FULL_V
        if charging and not self.apad.energy.charging:
            self.apad.energy.home_charges += 1
        self.apad.energy.charging = charging
        if charging:
            wh = home_charge_wh(state.battery_v, p, dt_s)
            self.apad.energy.home_wh += wh
            self._set_volts(volts_after(state.battery_v, wh, p))
            return wh
        return 0.0

    def could_charge(self) -> bool:
        """Whether the hull is where and as still as home charging needs (a rest there would charge)."""
        return could_charge(self.apad.state, self.apad.params)

    def _latched(self) -> set[int]:
        """The aMussels on a slot: latched, or being let go (what they reported up to the release was charged
        here: the fleet reports one as its slot releases it, `mussel_sim.comms`)."""
        return {s.mussel_id for s in self.apad.primitive.slots if s.mussel_id and s.latch in _ON_SLOT}

    def _set_volts(self, volts: float) -> None:
        self.apad.state = replace(self.apad.state, battery_v=volts)
