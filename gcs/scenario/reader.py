"""Scenario files (TOML): what a mission run is, validated into frozen dataclasses.

A bad file gets one `ScenarioError` line naming the file, the field and what is wrong.
Paths inside a scenario are relative to the scenario file. Durations are strings with their
unit: "90s", "40min", "1.5h" (`missiontime.durations`). A scenario named on the command line is
looked for in the working directory first, then among the shipped missions/ (`resolve_scenario`).
"""

from __future__ import annotations

import difflib
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

# ScenarioError and out_of_range are read from here by the rest of the package, parse_duration_s by tests.
from acoustic.params import AcousticParams
from gcs.scenario.acoustic_table import read_acoustic
from gcs.scenario.fields import REQUIRED, Derived, Fields, FieldTable, ScenarioError
from gcs.scenario.fields import out_of_range as out_of_range
from gcs.strategies import COLLECT, REDEPLOY, RedeployStrategy, StrategyError, load_strategy
from missiontime.durations import MAX_MISSION_S
from missiontime.durations import parse_duration_s as parse_duration_s
from mussel_sim.battery import CHARGE_PROFILES, DISCHARGE_PROFILES
from mussel_sim.behaviour import (
    BEHAVIOURS,
    DEFAULT_BEHAVIOUR,
    HOURLY_WAKE_AWAKE_S,
    HOURLY_WAKE_INTERVAL_S,
    SLEEP_CHARGE,
)
from mussel_sim.report_policy import STATUS_KEEPALIVE_S

MISSIONS_DIR = Path(__file__).resolve().parents[2] / "missions"
MAX_DURATION_S = MAX_MISSION_S
THETA_RANGE = (1e-3, 1e4)  # aMussel time scale, for the file and `--theta`
SEED_MAX = 2**63 - 1  # seeds are int64 in results and folder names
MAX_CURRENT_MPS = 5.0  # per component: more is not a sea we work in (as `vil sitl --current`)


@dataclass(frozen=True)
class FleetConfig:
    count: int
    area: Path  # GeoJSON polygon the aMussels live in
    start_config: Path | None  # saved ids/positions/batteries; None: generate from the seed
    battery_min: float
    battery_max: float
    discharge: str  # battery profile names (mussel_sim.battery)
    charge: str
    drift_cm: float  # half-width of the per-step uniform random drift, per axis
    acoustic_range_m: float
    surfacing_time_s: float
    sinking_time_s: float
    status_rate_hz: float
    sensors_rate_hz: float
    status_keepalive_s: float  # an aMussel whose state has not changed reports this often (0: every publish)
    sensor_field: str  # "anoxic_patch" or "dummy"
    # Real aMussels expected on the bridge (`vil gcs --bridge`), beside the simulated ones. An id that is
    # also simulated is refused at start, unless the real one is to replace the simulated one.
    real_ids: tuple[int, ...] = ()
    real_replaces_simulated: bool = False
    # Behaviour profiles (mussel_sim.behaviour, docs/long_term.md): every aMussel's, and those of the
    # aMussels listed under another profile in [fleet.profiles] (profile name, ids), in BEHAVIOURS order.
    profile: str = DEFAULT_BEHAVIOUR
    profiles: tuple[tuple[str, tuple[int, ...]], ...] = ()
    sleep_charge: str = SLEEP_CHARGE  # hourly_wake's charge profile
    wake_interval_s: float = HOURLY_WAKE_INTERVAL_S  # hourly_wake's schedule (simulated s): Table I's by default
    awake_s: float = HOURLY_WAKE_AWAKE_S


@dataclass(frozen=True)
class ApadConfig:
    system_id: int
    home_lat_deg: float
    home_lon_deg: float
    speed_mps: float
    victory_radius_m: float
    dock_reach_m: float
    dock_time_s: float
    undock_time_s: float
    battery_end_v: float  # the mission ends when the aPad battery falls to this
    battery_wh: float = 400.0  # its battery's energy over 10.5..16 V (apad_sitl.energy)
    home_charge_w: float = 150.0  # its home charger; 0: none


@dataclass(frozen=True)
class MissionConfig:
    duration_s: float
    theta: float  # aMussel time scale: simulated seconds per mission second
    pool_threshold: float  # below this battery an aMussel is a charging candidate
    charged_threshold: float  # docked aMussels are released above this
    min_pool: int  # idle until this many candidates
    collect_strategy: str  # a registered strategy's name: shipped, or loaded from outside (strategies.plugins)
    redeploy_strategy: str  # a RedeployStrategy
    distance_scale: float  # planner cost scale factors
    energy_scale: float
    # The paper counts the sinking after a release as uptime (eq. 3); false: only once on the seabed.
    sinking_counts_active: bool = True


@dataclass(frozen=True)
class EnvironmentConfig:
    current_east_mps: float  # uniform water current, felt by the aPad and the aMussels alike
    current_north_mps: float


@dataclass(frozen=True)
class Scenario:
    name: str
    path: Path
    seed: int
    fleet: FleetConfig
    apads: tuple[ApadConfig, ...]  # one `[apad]` table, or several `[[apad]]` (a swarm), by system id
    mission: MissionConfig
    environment: EnvironmentConfig
    acoustic: AcousticParams = field(default_factory=AcousticParams)  # [acoustic]: off by default (docs/acoustic.md)

    @property
    def apad(self) -> ApadConfig:
        """The first aPad (the only one, in the paper's scenarios)."""
        return self.apads[0]

    def with_overrides(
        self,
        strategy: str | None = None,
        seed: int | None = None,
        duration_s: float | None = None,
        theta: float | None = None,
    ) -> Scenario:
        mission = self.mission
        if strategy is not None:
            mission = replace(mission, collect_strategy=load_strategy(strategy))
        if duration_s is not None:
            mission = replace(mission, duration_s=duration_s)
        if theta is not None:
            mission = replace(mission, theta=theta)
        return replace(self, mission=mission, seed=self.seed if seed is None else seed)


def shipped_scenarios() -> list[str]:
    """The names of the scenarios in missions/."""
    return sorted(p.stem for p in MISSIONS_DIR.glob("*.toml"))


def resolve_scenario(name: str | Path) -> Path:
    """The scenario file `name` stands for: the path from the working directory first (with .toml
    added if it has no suffix), then the same in the shipped missions/ (a leading "missions/" taken
    off); `ScenarioError` (one line listing the shipped ones) if neither holds it."""
    path = Path(name)
    inner = Path(*path.parts[1:]) if len(path.parts) > 1 and path.parts[0] == MISSIONS_DIR.name else path
    tries = [path, MISSIONS_DIR / path, MISSIONS_DIR / inner]
    if path.suffix == "":
        tries = [t.with_name(f"{t.name}.toml") if k % 2 else t for t in tries for k in (0, 1)]
    for candidate in tries:
        if candidate.is_file():
            return candidate
    shipped = shipped_scenarios()
    close = difflib.get_close_matches(path.stem.lower(), shipped, n=1, cutoff=0.6)  # Pool12, pool21
    hint = f"; did you mean {close[0]}?" if close else ""
    raise ScenarioError(f"{name}: no such scenario file, here or in {MISSIONS_DIR}{hint} "
                        f"(shipped: {', '.join(shipped)})")


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario file, found by `resolve_scenario` ("pool12" is missions/pool12.toml)."""
    path = resolve_scenario(path)
    return scenario_from_data(path, read_toml(path))


def read_toml(path: Path, error: type[ValueError] = ScenarioError, what: str = "scenario file") -> dict[str, Any]:
    """A TOML file's tables, or `error` with one line (no such file, unreadable, not TOML); `vil sweep`'s spec too."""
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise error(f"{path}: no such {what}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise error(f"{path}: cannot read: {exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{path}: not valid TOML: {exc}") from None


def scenario_from_data(path: Path, data: dict[str, Any]) -> Scenario:
    """Validate a scenario's parsed TOML (`vil sweep` patches fields into it); paths are relative to `path`."""
    return read_scenario(FieldTable(path, data, ""), path)


def _collect_strategy(m: Fields, path: Path) -> str:
    """A shipped strategy, or one from outside the package loaded now (a file from the scenario's folder)."""
    spec = m.text("collect_strategy", "cautious", about=f"shipped: {', '.join(COLLECT)}; or FILE.py:FUNCTION (from "
                  "the scenario's folder), MODULE:FUNCTION, an installed vil.strategies entry point")
    try:
        return load_strategy(spec, path.parent)
    except StrategyError as exc:
        raise m.fail("collect_strategy", str(exc)) from None


def read_scenario(root: Fields, path: Path) -> Scenario:
    """The one reader of scenario data, field by field: from a `FieldTable` it checks a file; from
    `scenario_schema.SchemaTable` it writes the JSON Schema of the format (so each field is described
    here, once: kind, default, range, choices, and in `about` what it means where its name does not say)."""
    top = root.sub("scenario")
    name = _own_name(top.text("name", Derived(path.stem, "the file's name without .toml"),
                              about="names the run folders and results; a shipped scenario's name in a copy "
                                    "of it elsewhere: the copy's file name without .toml"), path)
    seed = top.integer("seed", 1, lo=0, hi=SEED_MAX, about="the seed of every random draw (a drawn fleet too)")
    top.done()

    m = root.sub("mission")
    mission = MissionConfig(
        duration_s=m.duration("duration", "40m", about="mission time"),
        theta=m.number("theta", 30.0, *THETA_RANGE, about="aMussel time scale: simulated seconds per mission second"),
        pool_threshold=m.number("pool_threshold", 0.8, lo=0.0, hi=1.0,
                                about="below this battery an aMussel is a charging candidate"),
        charged_threshold=m.number("charged_threshold", 0.99, lo=0.0, hi=1.0,
                                   about="docked aMussels are released above this battery"),
        min_pool=m.integer("min_pool", 4, lo=1, hi=4, about="the aPad idles until this many candidates"),
        collect_strategy=_collect_strategy(m, path),
        redeploy_strategy=RedeployStrategy(m.text("redeploy_strategy", "greedy", REDEPLOY)),
        distance_scale=m.number("distance_scale", 1.0, lo=0.0),
        energy_scale=m.number("energy_scale", 40.0, lo=0.0,
                              about="weighted: metres per battery lacking (docs/strategies.md)"),
        sinking_counts_active=m.flag("sinking_counts_active", True, about="the sinking after a release counts as "
                                     "uptime, as in the paper (eq. 3); false: only once on the seabed"),
    )
    m.done()

    e = root.sub("environment")
    current = e.pair("current_mps", [0.0, 0.0], -MAX_CURRENT_MPS, MAX_CURRENT_MPS,
                     about="uniform water current [east, north], felt by the aPad and the aMussels alike")
    environment = EnvironmentConfig(current[0], current[1])
    e.done()

    f = root.sub("fleet")
    battery = f.pair("start_battery", [0.6, 1.0], 0.0, 1.0, about="[min, max] of a drawn fleet's batteries")
    fleet = FleetConfig(
        count=f.integer("count", REQUIRED, lo=1, hi=65535, about="simulated aMussels"),
        area=f.file("area", REQUIRED, about="GeoJSON polygon the aMussels live in"),  # type: ignore[arg-type]
        start_config=f.file("start_config", None, about="saved ids, positions and batteries (GeoJSON); "
                            "absent: the fleet is drawn from the seed"),
        battery_min=battery[0],
        battery_max=battery[1],
        discharge=f.text("discharge", "active", tuple(DISCHARGE_PROFILES),
                         about="the always_on profile's discharge model (active: eq. 1)"),
        charge=f.text("charge", "secondary", tuple(CHARGE_PROFILES),
                      about="the always_on profile's charge model (secondary: eq. 2)"),
        drift_cm=f.number("drift_cm", 0.5, lo=0.0, hi=100.0,
                          about="half-width of the per-step uniform random drift, per axis"),
        acoustic_range_m=f.number("acoustic_range_m", 100.0, lo=0.0, hi=100_000.0),
        surfacing_time_s=f.number("surfacing_time_s", 20.0, lo=0.0, hi=3600.0),
        sinking_time_s=f.number("sinking_time_s", 20.0, lo=0.0, hi=3600.0),
        status_rate_hz=f.number("status_rate_hz", 1.0, lo=0.01, hi=50.0),
        sensors_rate_hz=f.number("sensors_rate_hz", 0.2, lo=0.01, hi=50.0),
        status_keepalive_s=f.number("status_keepalive_s", STATUS_KEEPALIVE_S, lo=0.0, hi=3600.0,
                                    about="an aMussel whose state has not changed reports this often, one that "
                                          "changed at once; the GCS runs the battery model between (0: every "
                                          "aMussel at every status publish, the paper's 1 Hz)"),
        sensor_field=f.text("sensor_field", "anoxic_patch", ("anoxic_patch", "dummy")),
        real_ids=f.integers("real_ids", 1, 65535, about="real aMussels expected on the bridge (vil gcs --bridge)"),
        real_replaces_simulated=f.flag("real_replaces_simulated",
                                       about="a real id that is also simulated replaces the simulated one"),
        profile=f.text("profile", DEFAULT_BEHAVIOUR, BEHAVIOURS,
                       about="every aMussel's behaviour profile (Table I): always_on, the paper's (MU on all the "
                             "time); hourly_wake, asleep on the seabed waking hourly for 10 s (docs/long_term.md)"),
        profiles=_profiles(f),
        sleep_charge=f.text("sleep_charge", SLEEP_CHARGE, tuple(CHARGE_PROFILES),
                            about="the hourly_wake profile's charge model (primary_sleep: Table I, 398 min)"),
        wake_interval_s=f.number("wake_interval_s", HOURLY_WAKE_INTERVAL_S, lo=60.0, hi=86400.0,
                                 about="the hourly_wake profile's wake interval, simulated seconds (Table I: 3600); "
                                       "another schedule than Table I's drains by the duty-cycle model "
                                       "(docs/long_term.md)"),
        awake_s=f.number("awake_s", HOURLY_WAKE_AWAKE_S, lo=1.0, hi=1800.0,
                         about="the hourly_wake profile's time awake at each wake, simulated seconds (Table I: 10)"),
    )
    if fleet.awake_s >= fleet.wake_interval_s:
        raise f.fail("awake_s", f"expected less than wake_interval_s ({fleet.wake_interval_s:g} s)")
    if not 0.0 <= fleet.battery_min <= fleet.battery_max <= 1.0:
        raise f.fail("start_battery", "expected 0 <= min <= max <= 1")
    f.done()

    apads = tuple(_apad(a, default_id=1 + i) for i, a in enumerate(
        root.tables("apad", about="one aPad ([apad]) or several ([[apad]], a swarm), by system id")))
    ids = [a.system_id for a in apads]
    if len(set(ids)) != len(ids):
        raise root.fail("apad", f"system ids must differ, got {ids}")
    acoustic = read_acoustic(root.sub("acoustic", about="the acoustic channel, TDMA and the nanomodem "
                                      "(docs/acoustic.md); off unless enabled"))
    if acoustic.enabled and fleet.count > 255:
        raise root.fail("acoustic", f"the nanomodem's addresses allow 255 aMussels, got {fleet.count}")
    root.done()
    return Scenario(name, path.resolve(), seed, fleet, apads, mission, environment, acoustic)


def _own_name(given: str, path: Path) -> str:
    """The name a scenario runs under. A copy of a shipped scenario (`cp missions/pool12.toml mine.toml`)
    carries the shipped one's `name` along with the rest: under it, its runs would land among the
    shipped scenario's and `--resume` would pick theirs. So a shipped scenario's name is the shipped
    file's only; in any other file it gives way to that file's own name. A name of one's own is kept."""
    shipped = MISSIONS_DIR / f"{given}.toml"
    if given and given != path.stem and shipped.is_file() and shipped.resolve() != path.resolve():
        return path.stem
    return given


def _profiles(f: Fields) -> tuple[tuple[str, tuple[int, ...]], ...]:
    """[fleet.profiles]: a behaviour profile's name -> the aMussel ids that follow it instead of
    fleet.profile; an id under two names is refused (ids outside the fleet: `check_inputs`)."""
    p = f.sub("profiles", about="aMussels on another profile than fleet.profile: profile name = [ids]")
    given = tuple((name, ids) for name in BEHAVIOURS
                  if (ids := p.integers(name, 1, 65535, about=f"aMussel ids on the {name} profile")))
    seen: dict[int, str] = {}
    for name, ids in given:
        for i in ids:
            if seen.setdefault(i, name) != name:
                raise p.fail(name, f"aMussel {i} is also under {seen[i]}")
    p.done()
    return given


def _apad(a: Fields, default_id: int) -> ApadConfig:
    home = a.pair("home", REQUIRED, -180.0, 180.0, about="[lat, lon] in degrees")
    if not (-90 <= home[0] <= 90 and -180 <= home[1] <= 180):
        raise a.fail("home", f"{list(home)} is not [lat, lon] in degrees")
    apad = ApadConfig(
        system_id=a.integer("system_id", Derived(default_id, "its place among the aPads, from 1"), lo=1, hi=249,
                            about="MAVLink system id"),
        home_lat_deg=home[0],
        home_lon_deg=home[1],
        speed_mps=a.number("speed_mps", 0.5, lo=0.01, hi=5.0),
        victory_radius_m=a.number("victory_radius_m", 1.0, lo=0.05, hi=50.0),
        dock_reach_m=a.number("dock_reach_m", 2.0, lo=0.1, hi=50.0),
        dock_time_s=a.number("dock_time_s", 10.0, lo=0.0, hi=600.0),
        undock_time_s=a.number("undock_time_s", 5.0, lo=0.0, hi=600.0),
        battery_end_v=a.number("battery_end_v", 11.0, lo=10.5, hi=16.0,
                               about="the mission ends when the aPad battery falls to this"),
        battery_wh=a.number("battery_wh", 400.0, lo=1.0, hi=100_000.0,
                            about="the aPad battery's energy between 10.5 and 16 V, Wh (docs/energy.md)"),
        home_charge_w=a.number("home_charge_w", 150.0, lo=0.0, hi=10_000.0,
                               about="the home charger's power, W; 0: no charger"),
    )
    a.done()
    return apad
