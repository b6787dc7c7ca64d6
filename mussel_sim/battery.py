"""aMussel battery: the paper's normalised-voltage models, vectorised over the whole fleet.

Every coefficient lives in this module, named, with the paper's value (Babić, Vasiljević,
Mišković, "Vehicle-in-the-loop framework for testing long-term autonomy in a heterogeneous
marine robot swarm", section IV-A, eqs. (1)-(2) and Table I).

u is the battery voltage normalised to [0, 1]: 3600 mV -> 0 (lowest safe voltage, the aMussel may
no longer be able to surface below it), 4200 mV -> 1 (full). Rates are in u per *simulated*
minute; a step of `dt_s` seconds of mission time advances simulated time by `theta * dt_s / 60`
minutes (paper: theta = 30, 1 Hz steps).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from types import MappingProxyType

import numpy as np
from numpy.typing import ArrayLike, NDArray

# --- Paper coefficients (section IV-A) -------------------------------------------------------

# Voltage window mapped to u in [0, 1].
EMPTY_MV = 3600.0
FULL_MV = 4200.0

# Eq. (1), linear least-squares fit of the "MU turned on but idle" discharge: u per minute.
DISCHARGE_ACTIVE_PER_MIN = 0.0010427134

# Eq. (2), piecewise-linear fit of the secondary-battery charge: band upper bounds on u_{k-1}
# (inclusive) and the rate of each band, u per minute.
CHARGE_SECONDARY_THRESHOLDS = (0.16197, 0.5634)
CHARGE_SECONDARY_PER_MIN = (0.001045, 0.00223, 0.002911)

# Table I, times to full discharge / full charge, minutes. Only the two equations above are
# fitted in the paper; the other rows are modelled as linear over [0, 1] (rate = 1 / time).
TABLE1_DISCHARGE_ACTIVE_IDLE_MIN = 962.0  # MU on but idle (eq. (1) is its fit: 959.04 min)
TABLE1_DISCHARGE_SLEEP_MIN = 14057.0  # MU asleep, waking once an hour
TABLE1_CHARGE_PRIMARY_IDLE_MIN = 575.0  # primary battery, MU on but idle
TABLE1_CHARGE_PRIMARY_SLEEP_MIN = 398.0  # primary battery, MU waking once an hour
TABLE1_CHARGE_SECONDARY_MIN = 485.0  # secondary battery (eq. (2) is its fit: 484.99 min)

# Eq. (1)-(2): dt in minutes; the simulator steps at 1 Hz, i.e. dt = 1/60 min per step.
SECONDS_PER_MIN = 60.0


@dataclass(frozen=True)
class DischargeProfile:
    """Linear discharge: u decreases by `rate_per_min` per simulated minute."""

    name: str
    rate_per_min: float


@dataclass(frozen=True)
class ChargeProfile:
    """Piecewise-linear charge: band i applies while u_{k-1} <= thresholds[i] (the last band above).

    `rates_per_min` has one more entry than `thresholds`; thresholds are increasing.
    """

    name: str
    thresholds: tuple[float, ...]
    rates_per_min: tuple[float, ...]

    def __post_init__(self) -> None:
        if len(self.rates_per_min) != len(self.thresholds) + 1:
            raise ValueError(f"charge profile {self.name!r}: need len(thresholds) + 1 rates")
        if list(self.thresholds) != sorted(self.thresholds):
            raise ValueError(f"charge profile {self.name!r}: thresholds must increase")

    def rate_per_min(self, battery_frac: NDArray[np.float64]) -> NDArray[np.float64]:
        """Charge rate of each u `(n,)`, chosen from the band of u (the value before the step)."""
        thresholds, rates = self._arrays
        # side="left": u exactly at a threshold stays in the lower band, as eq. (2) writes it.
        return rates[thresholds.searchsorted(battery_frac, side="left")]

    @cached_property
    def _arrays(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The bands as arrays, made once: every step of a docked aMussel looks its rate up."""
        return np.asarray(self.thresholds, float), np.asarray(self.rates_per_min, float)


DISCHARGE_PROFILES: MappingProxyType[str, DischargeProfile] = MappingProxyType(
    {
        p.name: p
        for p in (
            DischargeProfile("active", DISCHARGE_ACTIVE_PER_MIN),
            DischargeProfile("active_idle_table", 1.0 / TABLE1_DISCHARGE_ACTIVE_IDLE_MIN),
            DischargeProfile("sleep", 1.0 / TABLE1_DISCHARGE_SLEEP_MIN),
        )
    }
)

CHARGE_PROFILES: MappingProxyType[str, ChargeProfile] = MappingProxyType(
    {
        p.name: p
        for p in (
            ChargeProfile("secondary", CHARGE_SECONDARY_THRESHOLDS, CHARGE_SECONDARY_PER_MIN),
            ChargeProfile("secondary_table", (), (1.0 / TABLE1_CHARGE_SECONDARY_MIN,)),
            ChargeProfile("primary_idle", (), (1.0 / TABLE1_CHARGE_PRIMARY_IDLE_MIN,)),
            ChargeProfile("primary_sleep", (), (1.0 / TABLE1_CHARGE_PRIMARY_SLEEP_MIN,)),
        )
    }
)

DEFAULT_DISCHARGE = "active"
DEFAULT_CHARGE = "secondary"


def discharge_profile(name: str) -> DischargeProfile:
    try:
        return DISCHARGE_PROFILES[name]
    except KeyError:
        raise ValueError(f"unknown discharge profile {name!r}; known: {sorted(DISCHARGE_PROFILES)}") from None


def charge_profile(name: str) -> ChargeProfile:
    try:
        return CHARGE_PROFILES[name]
    except KeyError:
        raise ValueError(f"unknown charge profile {name!r}; known: {sorted(CHARGE_PROFILES)}") from None


def sim_minutes(theta: float, dt_s: float) -> float:
    """Simulated minutes one step of `dt_s` mission seconds represents."""
    return theta * (dt_s / SECONDS_PER_MIN)


def step_battery(
    battery_frac: NDArray[np.float64],
    charging: NDArray[np.bool_],
    discharge: DischargeProfile,
    charge: ChargeProfile,
    theta: float,
    dt_s: float,
) -> NDArray[np.float64]:
    """One step of eqs. (1)-(2) for every agent, clamped to [0, 1]; returns a new array.

    battery_frac `(n,)`: u_{k-1}. charging `(n,)`: True where the agent charges (docked), False
    where it discharges. Agents already at 0 stay at 0 unless charging.
    """
    dt_min = sim_minutes(theta, dt_s)
    out = battery_frac - discharge.rate_per_min * dt_min
    idx = charging.nonzero()[0]
    if idx.size:  # usually a handful of docked agents: rate lookup on the subset only
        u = battery_frac[idx]
        out[idx] = u + charge.rate_per_min(u) * dt_min
    np.maximum(out, 0.0, out=out)
    np.minimum(out, 1.0, out=out)
    return out


def to_millivolts(battery_frac: ArrayLike) -> NDArray[np.float64]:
    """Battery voltage [mV] of normalised u (the inverse of the paper's [3600, 4200] -> [0, 1])."""
    return EMPTY_MV + np.asarray(battery_frac, float) * (FULL_MV - EMPTY_MV)


def from_millivolts(voltage_mv: ArrayLike) -> NDArray[np.float64]:
    """Normalised u of a voltage [mV], clamped to [0, 1]."""
    return np.clip((np.asarray(voltage_mv, float) - EMPTY_MV) / (FULL_MV - EMPTY_MV), 0.0, 1.0)
