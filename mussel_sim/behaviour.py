"""aMussel behaviour profiles (Table I of the paper) and the duty-cycle energy model of a sleep order.

A `BehaviourProfile` is what an aMussel does while deployed and how it charges: its discharge while
deployed (every state but DOCKED), its charge profile while docked, and its wake schedule (a wake
every `wake_interval_s`, awake for `awake_s`; None for an aMussel that is always on). Two ship, from
Table I:

- `always_on`: the paper's experiments ("MU turned on but idle"): eq. (1) discharge (959.04 min to
  empty; Table I measured 962), eq. (2) secondary-battery charge (485 min), monitoring all the time.
- `hourly_wake`: asleep on the seabed, waking once an hour for about 10 s to sample every sensor:
  empty in 14,057 min (Table I), charged by the primary battery with the MU waking hourly (398 min).

Times of a schedule are the aMussel's own (simulated) seconds: at theta = 30 an hourly wake comes
every 2 minutes of mission time. The schedule itself (phases, next wake) is `mussel_sim.wake`.

Duty-cycle model of a sleep order (an assumption between two measured points). Table I measured two
behaviours only: always on (full discharge in 962 min) and asleep waking hourly for ~10 s (14,057
min). An order (interval I, awake a) has duty d = a / I; its power is modelled as sleep power plus
the duty's share of the difference to the always-on power, linear in d:

    rate(d) = SLEEP_PER_MIN + d * (ON_PER_MIN - SLEEP_PER_MIN)      [u per simulated minute]

with ON_PER_MIN = 1/962 (d = 1) and SLEEP_PER_MIN chosen so that d = 10/3600 gives 1/14057 exactly
(SLEEP_PER_MIN = 6.844e-5 per min: 14,611 min to empty asleep throughout). Nothing between or
beyond those two points was measured: waking costs (booting the MU, the sensors' warm-up) that do
not scale with the awake time are folded into the hourly point, so short wakes at short intervals
are likely cheaper here than on a real aMussel. An order's charge profile is its aMussel's
profile's (the order is about the deployed behaviour).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from mussel_sim.battery import (
    DEFAULT_CHARGE,
    DEFAULT_DISCHARGE,
    TABLE1_DISCHARGE_ACTIVE_IDLE_MIN,
    TABLE1_DISCHARGE_SLEEP_MIN,
    ChargeProfile,
    DischargeProfile,
    charge_profile,
    discharge_profile,
    sim_minutes,
)

# --- Table I's sleeping behaviour ----------------------------------------------------------------

HOURLY_WAKE_INTERVAL_S = 3600.0  # "waking up once every hour"
HOURLY_WAKE_AWAKE_S = 10.0  # "for about 10 seconds in order to record measurements from all sensors"
SLEEP_DISCHARGE = "sleep"  # battery.DISCHARGE_PROFILES: 1 / TABLE1_DISCHARGE_SLEEP_MIN
SLEEP_CHARGE = "primary_sleep"  # battery.CHARGE_PROFILES: Table I, primary battery, waking hourly (398 min)

ALWAYS_ON = "always_on"
HOURLY_WAKE = "hourly_wake"
BEHAVIOURS = (ALWAYS_ON, HOURLY_WAKE)  # the shipped profiles, in table order
DEFAULT_BEHAVIOUR = ALWAYS_ON

# --- the duty-cycle model (see the module docstring) ---------------------------------------------

ON_PER_MIN = 1.0 / TABLE1_DISCHARGE_ACTIVE_IDLE_MIN  # duty 1: Table I, MU on but idle (962 min)
HOURLY_DUTY = HOURLY_WAKE_AWAKE_S / HOURLY_WAKE_INTERVAL_S
HOURLY_PER_MIN = 1.0 / TABLE1_DISCHARGE_SLEEP_MIN  # duty 10/3600: Table I, waking hourly (14,057 min)
SLEEP_PER_MIN = (HOURLY_PER_MIN - HOURLY_DUTY * ON_PER_MIN) / (1.0 - HOURLY_DUTY)  # duty 0, derived

# A sleep order's interval: 0 (always on) or within these bounds (aMussel seconds).
MIN_WAKE_INTERVAL_S = 1.0
MAX_WAKE_INTERVAL_S = 30 * 86400.0


def duty_cycle_rate_per_min(interval_s: float, awake_s: float) -> float:
    """Discharge, u per simulated minute, of an aMussel waking every `interval_s` for `awake_s`
    (interval 0: always on, duty 1). The linear duty-cycle model between Table I's two points."""
    duty = 1.0 if interval_s == 0 else min(awake_s / interval_s, 1.0)
    return SLEEP_PER_MIN + duty * (ON_PER_MIN - SLEEP_PER_MIN)


def sleep_order_problem(interval_s: float, awake_s: float) -> str | None:
    """Why (interval, awake) is no sleep order, as a drop reason, or None: NaN, infinite or negative
    values, an interval out of [MIN, MAX] (but 0, always on), an awake time longer than the interval."""
    if not (interval_s == 0 or MIN_WAKE_INTERVAL_S <= interval_s <= MAX_WAKE_INTERVAL_S):  # NaN fails both
        return "interval"
    if not (math.isfinite(awake_s) and awake_s >= 0):
        return "awake"
    if interval_s > 0 and awake_s > interval_s:
        return "awake_over_interval"
    return None


@dataclass(frozen=True)
class BehaviourProfile:
    """What an aMussel does while deployed and how it charges (see the module docstring).

    discharge: u per simulated minute while deployed (ACTIVE, SURFACING, FLOATING, SINKING).
    charge: while DOCKED. wake_interval_s, awake_s: its wake schedule in simulated seconds, both None
    for an aMussel that is always on (monitoring all the time).
    """

    name: str
    discharge: DischargeProfile
    charge: ChargeProfile
    wake_interval_s: float | None = None
    awake_s: float | None = None

    def __post_init__(self) -> None:
        if (self.wake_interval_s is None) != (self.awake_s is None):
            raise ValueError(f"behaviour {self.name!r}: a wake interval and an awake time, or neither")
        if self.wake_interval_s is not None and self.awake_s is not None:
            problem = sleep_order_problem(self.wake_interval_s, self.awake_s)
            if problem is not None or self.wake_interval_s == 0:
                raise ValueError(f"behaviour {self.name!r}: bad wake schedule ({problem or 'interval'})")

    @property
    def scheduled(self) -> bool:
        return self.wake_interval_s is not None

    def ordered(self, interval_s: float, awake_s: float) -> BehaviourProfile:
        """This profile under a sleep order: the order's duty-cycle discharge and schedule, the same
        charge. Interval 0: always on (no schedule), at the model's duty-1 rate (Table I's 962 min)."""
        base = self.name.split("+", 1)[0]
        rate = duty_cycle_rate_per_min(interval_s, awake_s)
        if interval_s == 0:
            return BehaviourProfile(f"{base}+order:always_on", DischargeProfile("duty:always_on", rate), self.charge)
        tag = f"{interval_s:g}s/{awake_s:g}s"
        return BehaviourProfile(f"{base}+order:{tag}", DischargeProfile(f"duty:{tag}", rate), self.charge,
                                interval_s, awake_s)


def always_on(discharge: str = DEFAULT_DISCHARGE, charge: str = DEFAULT_CHARGE) -> BehaviourProfile:
    """The paper's profile: MU on all the time (by default eq. (1) and eq. (2), today's behaviour)."""
    return BehaviourProfile(ALWAYS_ON, discharge_profile(discharge), charge_profile(charge))


def hourly_wake(charge: str = SLEEP_CHARGE, interval_s: float = HOURLY_WAKE_INTERVAL_S,
                awake_s: float = HOURLY_WAKE_AWAKE_S) -> BehaviourProfile:
    """Table I's sleeping aMussel: awake ~10 s every hour, 14,057 min to empty; charge by default the
    primary battery's, waking hourly (398 min). Another schedule (a scenario's `fleet.wake_interval_s`,
    `fleet.awake_s`) drains by the duty-cycle model (the module's docstring), as a sleep order's does."""
    if (interval_s, awake_s) == (HOURLY_WAKE_INTERVAL_S, HOURLY_WAKE_AWAKE_S):
        discharge = discharge_profile(SLEEP_DISCHARGE)
    else:
        discharge = DischargeProfile(f"duty:{interval_s:g}s/{awake_s:g}s", duty_cycle_rate_per_min(interval_s, awake_s))
    return BehaviourProfile(HOURLY_WAKE, discharge, charge_profile(charge), interval_s, awake_s)


MAX_TABLE = 64  # profiles a table holds before the ones nobody uses any more are dropped


@dataclass(frozen=True)
class ProfileTable:
    """The profiles a fleet's aMussels point at (`FleetState.profile`, an index per aMussel), with
    their numbers as arrays `(k,)` so the step gathers them per aMussel without a Python loop.
    The shipped profiles come first (by `BEHAVIOURS`' order); sleep orders append their own."""

    profiles: tuple[BehaviourProfile, ...]
    rate_per_min: NDArray[np.float64] = field(init=False, repr=False, compare=False)
    interval_s: NDArray[np.float64] = field(init=False, repr=False, compare=False)  # 0: always on
    awake_s: NDArray[np.float64] = field(init=False, repr=False, compare=False)
    scheduled: NDArray[np.bool_] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not self.profiles:
            raise ValueError("a profile table holds at least one profile")
        arrays = {
            "rate_per_min": [p.discharge.rate_per_min for p in self.profiles],
            "interval_s": [p.wake_interval_s or 0.0 for p in self.profiles],
            "awake_s": [p.awake_s or 0.0 for p in self.profiles],
            "scheduled": [p.scheduled for p in self.profiles],
        }
        for name, values in arrays.items():
            a = np.asarray(values, bool if name == "scheduled" else np.float64)
            a.flags.writeable = False
            object.__setattr__(self, name, a)

    def __len__(self) -> int:
        return len(self.profiles)

    def index(self, name: str) -> int:
        for k, p in enumerate(self.profiles):
            if p.name == name:
                return k
        raise ValueError(f"unknown behaviour profile {name!r}; known: {', '.join(p.name for p in self.profiles)}")

    def with_profile(self, profile: BehaviourProfile) -> tuple[ProfileTable, int]:
        """This table with `profile` (appended unless it is there already) and its index."""
        if profile in self.profiles:
            return self, self.profiles.index(profile)
        return ProfileTable((*self.profiles, profile)), len(self.profiles)

    def compacted(self, profile: NDArray[np.uint16], keep: int) -> tuple[ProfileTable, NDArray[np.uint16]]:
        """The first `keep` profiles and those `profile` points at, and `profile` renumbered to them."""
        used = np.union1d(np.arange(keep), profile)
        renumber = np.zeros(len(self.profiles), np.uint16)
        renumber[used] = np.arange(used.size)
        return ProfileTable(tuple(self.profiles[k] for k in used)), renumber[profile]


def shipped_table(discharge: str = DEFAULT_DISCHARGE, charge: str = DEFAULT_CHARGE,
                  sleep_charge: str = SLEEP_CHARGE, wake_interval_s: float = HOURLY_WAKE_INTERVAL_S,
                  awake_s: float = HOURLY_WAKE_AWAKE_S) -> ProfileTable:
    """The shipped profiles (`BEHAVIOURS` order): always_on with the scenario's discharge and charge
    models (eq. (1) and (2) by default), hourly_wake with its charge model (primary, waking hourly) and
    its wake schedule (Table I's by default)."""
    return ProfileTable((always_on(discharge, charge), hourly_wake(sleep_charge, wake_interval_s, awake_s)))


def step_battery_profiles(
    battery_frac: NDArray[np.float64],
    charging: NDArray[np.bool_],
    table: ProfileTable,
    profile: NDArray[np.uint16],
    theta: float,
    dt_s: float,
) -> NDArray[np.float64]:
    """`battery.step_battery` with each aMussel's own profile `(n,)` (index into `table`): deployed
    ones discharge at their profile's rate, docked ones charge by their profile's charge profile;
    clamped to [0, 1]. With one rate and one charge profile for all, bit for bit `step_battery`."""
    dt_min = sim_minutes(theta, dt_s)
    out = battery_frac - table.rate_per_min[profile] * dt_min
    idx = charging.nonzero()[0]
    if idx.size:  # a handful of docked agents: one lookup per charge profile among them
        which = profile[idx]
        for k in np.unique(which):
            sel = idx[which == k]
            u = battery_frac[sel]
            out[sel] = u + table.profiles[int(k)].charge.rate_per_min(u) * dt_min
    np.maximum(out, 0.0, out=out)
    np.minimum(out, 1.0, out=out)
    return out
