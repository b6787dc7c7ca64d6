"""The aMussel fleet's state and its step's inputs and outputs: numpy arrays `(n,)`, one per
property, frozen and read-only (the model never mutates what it is given).

`FleetState` holds every agent; `FleetParams` the scenario's constants; `FleetInputs` what the
world asked of the fleet since the last step (dock, release, surface, sink, aPad positions);
`StepEvents` what the step did that the world must hear about. `mussel_sim.fleet.step` moves one
to the next.

Each aMussel follows a behaviour profile (`mussel_sim.behaviour`): `FleetState.profile` indexes the
state's `ProfileTable`, which the scenario's profiles start (`FleetParams.profile_table`) and sleep
orders extend.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from missiontime import US_PER_S
from mussel_sim.battery import (
    DEFAULT_CHARGE,
    DEFAULT_DISCHARGE,
    ChargeProfile,
    DischargeProfile,
    charge_profile,
    discharge_profile,
)
from mussel_sim.behaviour import (
    BEHAVIOURS,
    DEFAULT_BEHAVIOUR,
    HOURLY_WAKE_AWAKE_S,
    HOURLY_WAKE_INTERVAL_S,
    SLEEP_CHARGE,
    ProfileTable,
    shipped_table,
)
from mussel_sim.drift import NO_CURRENT, PAPER_DRIFT_HALF_WIDTH_M, CurrentField
from mussel_sim.geo import LocalFrame
from mussel_sim.startconfig import StartConfig, start_config_from_positions
from mussel_sim.vocabulary import MusselState
from mussel_sim.wake import next_wake_sim_s

ACTIVE = np.uint8(MusselState.ACTIVE)
SURFACING = np.uint8(MusselState.SURFACING)
FLOATING = np.uint8(MusselState.FLOATING)
DOCKED = np.uint8(MusselState.DOCKED)
SINKING = np.uint8(MusselState.SINKING)
DEPLETED = np.uint8(MusselState.DEPLETED)
N_STATES = max(MusselState) + 1

# The model takes uint32 ids so benchmarks can run 100,000 agents; MAVLink's mussel_id is uint16,
# which the comms runner enforces (MAX_MUSSEL_ID) before anything goes on the wire.
MAX_MODEL_ID = 2**32 - 1
# Timers count down in float seconds; a remainder this small is float noise, not time left.
TIMER_EPS_S = 1e-9

EMPTY_IDS: NDArray[np.int64] = np.zeros(0, np.int64)


def _ids(values: ArrayLike | None) -> NDArray[np.int64]:
    if values is None or (isinstance(values, list) and not values):  # most steps' inputs: nothing
        return EMPTY_IDS
    return np.asarray(values, dtype=np.int64).reshape(-1)


@dataclass(frozen=True)
class FleetParams:
    """Scenario parameters of the fleet model (mission time in seconds, distances in metres)."""

    theta: float = 30.0  # simulated minutes per mission minute (paper: 30)
    discharge_profile: str = DEFAULT_DISCHARGE  # name in battery.DISCHARGE_PROFILES
    charge_profile: str = DEFAULT_CHARGE  # name in battery.CHARGE_PROFILES
    surfacing_time_s: float = 20.0
    sinking_time_s: float = 20.0
    acoustic_range_m: float = 100.0  # an aMussel only surfaces with an aPad this close
    drift_half_width_m: float = PAPER_DRIFT_HALF_WIDTH_M  # per axis per step; 0 disables drift
    seabed_depth_m: float = 3.0  # depth of an ACTIVE aMussel
    current: CurrentField = NO_CURRENT
    profile: str = DEFAULT_BEHAVIOUR  # every aMussel's behaviour profile (mussel_sim.behaviour.BEHAVIOURS) ...
    profile_ids: tuple[tuple[str, tuple[int, ...]], ...] = ()  # ... but these: (profile name, aMussel ids)
    sleep_charge_profile: str = SLEEP_CHARGE  # hourly_wake's charge, a name in battery.CHARGE_PROFILES
    wake_interval_s: float = HOURLY_WAKE_INTERVAL_S  # hourly_wake's schedule, simulated s (Table I's: 3600 / 10)
    awake_s: float = HOURLY_WAKE_AWAKE_S
    _discharge: DischargeProfile = field(init=False, repr=False, compare=False)
    _charge: ChargeProfile = field(init=False, repr=False, compare=False)
    _profiles: ProfileTable = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if self.theta <= 0:
            raise ValueError(f"theta must be positive, got {self.theta}")
        if self.surfacing_time_s < 0 or self.sinking_time_s < 0:
            raise ValueError("surfacing/sinking times must be >= 0")
        object.__setattr__(self, "_discharge", discharge_profile(self.discharge_profile))
        object.__setattr__(self, "_charge", charge_profile(self.charge_profile))
        object.__setattr__(self, "_profiles", shipped_table(self.discharge_profile, self.charge_profile,
                                                            self.sleep_charge_profile, self.wake_interval_s,
                                                            self.awake_s))
        seen: dict[int, str] = {}
        for name in (self.profile, *(name for name, _ in self.profile_ids)):
            if name not in BEHAVIOURS:
                raise ValueError(f"unknown behaviour profile {name!r}; known: {', '.join(BEHAVIOURS)}")
        for name, ids in self.profile_ids:
            for i in ids:
                if seen.setdefault(i, name) != name:
                    raise ValueError(f"aMussel {i} is given two behaviour profiles, {seen[i]} and {name}")

    @property
    def profile_table(self) -> ProfileTable:
        """The shipped profiles with this scenario's battery models: a start state's table."""
        return self._profiles

    def start_profiles(self, ids: NDArray[np.int64]) -> NDArray[np.uint16]:
        """Each aMussel's index in `profile_table` `(n,)`: `profile`, or its own from `profile_ids`
        (ValueError for an id of `profile_ids` that `ids` does not hold)."""
        table = self._profiles
        out = np.full(ids.shape, table.index(self.profile), np.uint16)
        for name, listed in self.profile_ids:
            want = np.asarray(listed, np.int64)
            k = np.searchsorted(ids, want)
            known = (k < ids.size) & (ids[np.minimum(k, max(ids.size - 1, 0))] == want) if ids.size else want < 0
            if not known.all():
                raise ValueError(f"behaviour profile {name}: aMussel {int(want[~known][0])} is not in the fleet")
            out[k] = table.index(name)
        return out

    @property
    def discharge(self) -> DischargeProfile:
        return self._discharge

    @property
    def charge(self) -> ChargeProfile:
        return self._charge


@dataclass(frozen=True, eq=False)
class FleetState:
    """The whole fleet at one instant; arrays `(n,)`, sorted by id, read-only.

    ids: uint32 aMussel ids (unique, increasing; MAVLink carries 1..65535).
    x_m, y_m: east/north metres in the scenario's LocalFrame. depth_m: metres below the surface.
    battery_frac: normalised voltage u.
    state: uint8 MusselState. timer_s: mission seconds left in SURFACING/SINKING, else 0.
    dock_apad: aPad system id holding the agent, 0 if none. dock_slot: its slot 1..4, 0 if none.
    profile: uint16 index of each agent's behaviour profile in `profiles` (`mussel_sim.behaviour`).
    surface_held: a SURFACE command that reached the agent asleep, held for its next wake.
    next_wake_sim_s: simulated time [s] of the agent's first wake after `time_us` (`mussel_sim.wake`);
    +inf for an agent that is always on.
    samples_taken, samples_due: int64 wakes of its schedule since the start, ACTIVE on the seabed at
    the time / all of them (0 for an always-on agent: it monitors all the time).
    profiles: the behaviour profiles `profile` points at (the shipped ones first).
    time_us: mission time of this state. step_index: steps taken since the start state.
    """

    ids: NDArray[np.uint32]
    x_m: NDArray[np.float64]
    y_m: NDArray[np.float64]
    depth_m: NDArray[np.float64]
    battery_frac: NDArray[np.float64]
    state: NDArray[np.uint8]
    timer_s: NDArray[np.float64]
    dock_apad: NDArray[np.uint8]
    dock_slot: NDArray[np.uint8]
    profile: NDArray[np.uint16]
    surface_held: NDArray[np.bool_]
    next_wake_sim_s: NDArray[np.float64]
    samples_taken: NDArray[np.int64]
    samples_due: NDArray[np.int64]
    profiles: ProfileTable
    time_us: int = 0
    step_index: int = 0

    def __post_init__(self) -> None:
        # Read-only views: a model bug that writes into a previous state fails loudly. An array that
        # is read-only already (the step's own new arrays, made so) is kept as it is.
        for name in _STATE_ARRAYS:
            value = getattr(self, name)
            if type(value) is np.ndarray and not value.flags.writeable:
                continue
            view = np.asarray(value).view()
            view.flags.writeable = False
            object.__setattr__(self, name, view)

    @classmethod
    def of_step(cls, **fields: Any) -> FleetState:
        """A state the model's step made, every array read-only already (its own, made so, or the last
        state's): built without the views and checks a state from outside gets (a step's tenth)."""
        state = object.__new__(cls)
        state.__dict__.update(fields)
        return state

    @property
    def n(self) -> int:
        return int(self.ids.shape[0])

    @property
    def time_s(self) -> float:
        return self.time_us / US_PER_S

    def index_of(self, mussel_ids: ArrayLike) -> tuple[NDArray[np.intp], NDArray[np.bool_]]:
        """(indices, known) of `mussel_ids` `(k,)`; indices are only meaningful where known."""
        q = np.asarray(mussel_ids, dtype=np.int64).reshape(-1)
        if self.n == 0:
            return np.zeros(q.shape, np.intp), np.zeros(q.shape, bool)
        idx = np.minimum(np.searchsorted(self.ids, q), self.n - 1)
        return idx, self.ids[idx] == q

    def active_mask(self) -> NDArray[np.bool_]:
        return self.state == ACTIVE

    def arrays_equal(self, other: FleetState) -> bool:
        """Bit-for-bit equality of every array (dtype, shape and bytes) and counter."""
        return (
            self.time_us == other.time_us
            and self.step_index == other.step_index
            and self.profiles == other.profiles
            and all(_same_bits(getattr(self, a), getattr(other, a)) for a in _STATE_ARRAYS)
        )


def _same_bits(a: NDArray[np.generic], b: NDArray[np.generic]) -> bool:
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


_STATE_ARRAYS = tuple(f.name for f in fields(FleetState) if f.name not in ("time_us", "step_index", "profiles"))


def initial_state(config: StartConfig, frame: LocalFrame, params: FleetParams, time_us: int = 0) -> FleetState:
    """Every aMussel of `config` ACTIVE on the seabed (DEPLETED if its battery is 0), sorted by id."""
    x_m, y_m = frame.to_local(config.lat_deg, config.lon_deg)
    return state_from_arrays(config.ids, x_m, y_m, config.battery_frac, params, time_us)


def start_config_of(state: FleetState, frame: LocalFrame) -> StartConfig:
    """The start configuration that reproduces `state`'s ids, positions and batteries (any run, any step)."""
    return start_config_from_positions(state.ids, state.x_m, state.y_m, state.battery_frac, frame)


def state_from_arrays(
    ids: ArrayLike,
    x_m: ArrayLike,
    y_m: ArrayLike,
    battery_frac: ArrayLike,
    params: FleetParams,
    time_us: int = 0,
    state: ArrayLike | None = None,
) -> FleetState:
    """A start state from plain arrays `(n,)`; `state` defaults to ACTIVE (DEPLETED where u = 0)."""
    ids_a = np.asarray(ids, dtype=np.int64)
    order = np.argsort(ids_a, kind="stable")
    ids_a = ids_a[order]
    if ids_a.size and ((ids_a[1:] == ids_a[:-1]).any() or ids_a[0] < 1 or ids_a[-1] > MAX_MODEL_ID):
        raise ValueError(f"aMussel ids must be unique and in 1..{MAX_MODEL_ID}")
    n = ids_a.size
    u = np.clip(np.asarray(battery_frac, float)[order], 0.0, 1.0)
    st = np.where(u > 0, ACTIVE, DEPLETED).astype(np.uint8) if state is None else np.asarray(state, np.uint8)[order]
    if ((st == SURFACING) | (st == SINKING) | (st == DOCKED)).any():
        raise ValueError("a start state is ACTIVE, FLOATING or DEPLETED (no timers, no dock)")
    depth = np.where(st == FLOATING, 0.0, params.seabed_depth_m)
    profile = params.start_profiles(ids_a)
    return FleetState(
        ids=ids_a.astype(np.uint32),
        x_m=np.asarray(x_m, float)[order].copy(),
        y_m=np.asarray(y_m, float)[order].copy(),
        depth_m=depth,
        battery_frac=u,
        state=st,
        timer_s=np.zeros(n),
        dock_apad=np.zeros(n, np.uint8),
        dock_slot=np.zeros(n, np.uint8),
        profile=profile,
        surface_held=np.zeros(n, bool),
        next_wake_sim_s=next_wake_sim_s(ids_a, params.profile_table.interval_s[profile],
                                        params.theta * (time_us / US_PER_S)),
        samples_taken=np.zeros(n, np.int64),
        samples_due=np.zeros(n, np.int64),
        profiles=params.profile_table,
        time_us=time_us,
    )


@dataclass(frozen=True, eq=False)
class FleetInputs:
    """What happened to the fleet since the last step, by aMussel id.

    apad_ids `(m,)`: aPad system ids whose position is known; apad_x_m, apad_y_m `(m,)` in the
    scenario's LocalFrame. surface_ids, sink_ids `(k,)`: commanded aMussels. dock_ids,
    dock_apad, dock_slot `(k,)`: aMussel latched into slot of aPad. release_ids `(k,)`: aMussels
    their slot no longer holds. sleep_ids, sleep_interval_s, sleep_awake_s `(k,)`: sleep orders
    (validated: `behaviour.sleep_order_problem`; interval 0: always on). wake_ids `(k,)`: aMussels
    woken now (the seam for the acoustic wake-up ping: a held call-up is taken at once).
    """

    apad_ids: NDArray[np.int64] = field(default_factory=lambda: EMPTY_IDS)
    apad_x_m: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    apad_y_m: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    surface_ids: NDArray[np.int64] = field(default_factory=lambda: EMPTY_IDS)
    sink_ids: NDArray[np.int64] = field(default_factory=lambda: EMPTY_IDS)
    dock_ids: NDArray[np.int64] = field(default_factory=lambda: EMPTY_IDS)
    dock_apad: NDArray[np.int64] = field(default_factory=lambda: EMPTY_IDS)
    dock_slot: NDArray[np.int64] = field(default_factory=lambda: EMPTY_IDS)
    release_ids: NDArray[np.int64] = field(default_factory=lambda: EMPTY_IDS)
    sleep_ids: NDArray[np.int64] = field(default_factory=lambda: EMPTY_IDS)
    sleep_interval_s: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    sleep_awake_s: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    wake_ids: NDArray[np.int64] = field(default_factory=lambda: EMPTY_IDS)

    @classmethod
    def make(
        cls,
        apads: Mapping[int, tuple[float, float]] | None = None,
        surface: Iterable[int] = (),
        sink: Iterable[int] = (),
        dock: Iterable[tuple[int, int, int]] = (),
        release: Iterable[int] = (),
        sleep: Iterable[tuple[int, float, float]] = (),
        wake: Iterable[int] = (),
    ) -> FleetInputs:
        """Friendly constructor: apads {system_id: (x_m, y_m)}, dock [(mussel_id, apad_id, slot)],
        sleep [(mussel_id, interval_s, awake_s)].

        Most steps bring no command and the aPads' last positions as the same objects again (the comms
        runner keeps them until they move): that input is made once and given again (read-only)."""
        quiet = not (surface or sink or dock or release or sleep or wake) and all(
            isinstance(a, list) for a in (surface, sink, release))
        items = tuple((apads or {}).items())
        last = _LAST_QUIET
        if (quiet and last is not None and len(last[0]) == len(items)
                and all(k == j and v is w for (k, v), (j, w) in zip(items, last[0], strict=True))):
            return last[1]
        made = cls._make(dict(items), surface, sink, dock, release, sleep, wake)
        if quiet:
            for array in (made.apad_ids, made.apad_x_m, made.apad_y_m):
                if array is not EMPTY_IDS:  # shared by everyone: left as it is
                    array.flags.writeable = False
            _remember_quiet(items, made)
        return made

    @classmethod
    def _make(
        cls, apads: dict[int, tuple[float, float]], surface: Iterable[int], sink: Iterable[int],
        dock: Iterable[tuple[int, int, int]], release: Iterable[int],
        sleep: Iterable[tuple[int, float, float]] = (), wake: Iterable[int] = (),
    ) -> FleetInputs:
        docks = list(dock)
        orders = list(sleep)
        xy = np.asarray(list(apads.values()), float).reshape(-1, 2)
        return cls(
            apad_ids=_ids(list(apads)),
            apad_x_m=xy[:, 0].copy(),
            apad_y_m=xy[:, 1].copy(),
            surface_ids=_ids(list(surface)),
            sink_ids=_ids(list(sink)),
            dock_ids=_ids([d[0] for d in docks]),
            dock_apad=_ids([d[1] for d in docks]),
            dock_slot=_ids([d[2] for d in docks]),
            release_ids=_ids(list(release)),
            sleep_ids=_ids([o[0] for o in orders]),
            sleep_interval_s=np.asarray([o[1] for o in orders], np.float64),
            sleep_awake_s=np.asarray([o[2] for o in orders], np.float64),
            wake_ids=_ids(list(wake)),
        )


NO_INPUTS = FleetInputs()
_LAST_QUIET: tuple[tuple[tuple[int, tuple[float, float]], ...], FleetInputs] | None = None


def _remember_quiet(items: tuple[tuple[int, tuple[float, float]], ...], inputs: FleetInputs) -> None:
    global _LAST_QUIET
    _LAST_QUIET = (items, inputs)


@dataclass(frozen=True, eq=False)
class StepEvents:
    """What one step did, as aMussel ids `(k,)` (empty arrays when nothing happened)."""

    surface_accepted_ids: NDArray[np.uint32]
    surface_refused_out_of_range_ids: NDArray[np.uint32]  # safety: no aPad within acoustic range
    surface_refused_depleted_ids: NDArray[np.uint32]  # below 3600 mV it may not be able to surface
    ignored_command_ids: NDArray[np.uint32]  # surface/sink that mean nothing in the current state
    unknown_ids: NDArray[np.int64]  # ids in the inputs that this fleet does not simulate
    docked_ids: NDArray[np.uint32]
    docked_submerged_ids: NDArray[np.uint32]  # docked while ACTIVE/SINKING: a planner forgot to surface it
    released_ids: NDArray[np.uint32]
    floating_ids: NDArray[np.uint32]  # reached the surface this step
    resumed_ids: NDArray[np.uint32]  # reached the seabed this step, ACTIVE again
    depleted_ids: NDArray[np.uint32]  # battery reached 0 this step
    surface_held_ids: NDArray[np.uint32] = field(default_factory=lambda: _NO_EVENT_IDS)  # asleep: for its wake


_NO_EVENT_IDS: NDArray[np.uint32] = np.zeros(0, np.uint32)
_NO_EVENT_IDS.flags.writeable = False
