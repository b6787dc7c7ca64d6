"""What a scenario means to the models: fleet and aPad parameters, the start configuration, the
sensor field and the geofence, and a check that reads the scenario's files before a mission starts."""

from __future__ import annotations

import json
from collections.abc import Iterable
from dataclasses import replace

import numpy as np
import shapely

from apad_sitl.params import ApadParams
from apad_sitl.vocabulary import N_SLOTS
from gcs.scenario.reader import ApadConfig, Scenario, ScenarioError
from gcs.strategies import Outlook, PlanInput, StrategyError, is_plugin, plan
from mussel_sim.behaviour import BehaviourProfile
from mussel_sim.drift import NO_CURRENT, UniformCurrent
from mussel_sim.fleet_state import FleetParams
from mussel_sim.geo import LocalFrame
from mussel_sim.placement import Area, load_area
from mussel_sim.sensors import AnoxicPatch, DummySensors, SensorField
from mussel_sim.startconfig import StartConfig, generate_start_config, load_start_config

# A start point farther than this outside the area is a wrong file (another site, lat/lon swapped), not drift.
START_OUTSIDE_LIMIT_M = 100.0


def check_inputs(scenario: Scenario) -> None:
    """Read the scenario's area and start configuration now, so a bad file is one `ScenarioError` line
    (file: what is wrong) before any mission starts, never a traceback from the middle of one."""
    path, what = scenario.fleet.area, "area"
    simulated: Iterable[int] = range(1, scenario.fleet.count + 1)  # a drawn fleet's ids
    try:
        area = load_area(path)  # checks its vertices: finite WGS84 degrees, a valid polygon
        if scenario.fleet.start_config is not None:
            path, what = scenario.fleet.start_config, "start configuration"
            config = load_start_config(path)  # checks ids, positions, batteries
            if config.n != scenario.fleet.count:
                n = scenario.fleet.count
                raise ValueError(f"holds {config.n} aMussels, the scenario says {n} (to draw {n} from the seed: "
                                 "vil run --draw-fleet, draw_fleet = true in a sweep spec, or no "
                                 "fleet.start_config)")
            _check_inside(config, area)
            simulated = config.ids.tolist()
    except OSError as exc:
        raise ScenarioError(f"{path}: cannot read the {what}: {exc.strerror or exc}") from None
    except json.JSONDecodeError as exc:
        raise ScenarioError(f"{path}: the {what} is not JSON: {exc.msg} (line {exc.lineno})") from None
    except (ValueError, KeyError, TypeError, IndexError, AttributeError) as exc:
        detail = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise ScenarioError(f"{path}: bad {what}: {detail}") from None
    replaced = _real_and_simulated(scenario, simulated)
    _check_profile_ids(scenario, set(map(int, simulated)) - set(replaced))
    _probe_strategy(scenario, area)


def _check_profile_ids(scenario: Scenario, simulated: set[int]) -> None:
    """Every id of [fleet.profiles] is one of the simulated aMussels: one `ScenarioError` line naming the field."""
    for name, ids in scenario.fleet.profiles:
        stray = [i for i in ids if i not in simulated]
        if stray:
            raise ScenarioError(f"{scenario.path}: fleet.profiles.{name}: aMussel {stray[0]} is not in the simulated "
                                f"fleet ({len(simulated)} aMussels)")


def _probe_strategy(scenario: Scenario, area: Area) -> None:
    """A strategy from outside the package plans once on the mission's start (every aMussel a
    candidate, the first aPad at home with its four slots free), so a bad one is a line now, not an
    event at its first planning step."""
    name = scenario.mission.collect_strategy
    if not is_plugin(name):  # a shipped strategy: the suite tests it
        return
    config, _ = start_config(scenario, area, np.random.default_rng(scenario.seed))
    home = scenario.apads[0]
    inp = PlanInput(apads={home.system_id: (home.home_lat_deg, home.home_lon_deg)},
                    capacity={home.system_id: N_SLOTS}, mussel_ids=config.ids.astype(np.int64),
                    lat_deg=config.lat_deg, lon_deg=config.lon_deg, battery_frac=config.battery_frac,
                    outlook=Outlook(time_left_s=scenario.mission.duration_s, theta=scenario.mission.theta))
    try:
        plan(name, inp)
    except StrategyError as exc:
        raise ScenarioError(f"{exc} (tried on {scenario.name}'s start, before the mission)") from None


def _check_inside(config: StartConfig, area: Area) -> None:
    frame = area.frame()
    local = area.to_local(frame)
    x, y = frame.to_local(config.lat_deg, config.lon_deg)
    outside = shapely.distance(local, shapely.points(x, y))
    far = outside > START_OUTSIDE_LIMIT_M
    if far.any():
        k = int(np.argmax(far))
        raise ValueError(f"aMussel {config.ids[k]} starts {outside[k]:.0f} m outside the area "
                         f"(more than {START_OUTSIDE_LIMIT_M:.0f} m)")


def start_config(scenario: Scenario, area: Area, rng: np.random.Generator) -> tuple[StartConfig, LocalFrame]:
    """The simulated fleet: the scenario's saved start configuration, or one drawn from its area with
    the run's rng; without the ids of real aMussels that replace simulated ones (`fleet.real_ids`)."""
    frame = area.frame()
    if scenario.fleet.start_config is not None:
        config = load_start_config(scenario.fleet.start_config)
        if config.n != scenario.fleet.count:
            raise ValueError(
                f"{scenario.fleet.start_config}: holds {config.n} aMussels, the scenario says {scenario.fleet.count}"
            )
    else:
        battery = (scenario.fleet.battery_min, scenario.fleet.battery_max)
        config = generate_start_config(area, scenario.fleet.count, frame, rng, battery_range=battery)
    return _without_real(scenario, config), frame


def _real_and_simulated(scenario: Scenario, simulated_ids: Iterable[int]) -> list[int]:
    """Ids both real and simulated: refused, unless the real ones replace the simulated ones."""
    f = scenario.fleet
    both = sorted(set(f.real_ids) & {int(i) for i in simulated_ids})
    if both and not f.real_replaces_simulated:
        raise ScenarioError(
            f"{scenario.path}: fleet.real_ids: {', '.join(map(str, both))} also simulated aMussel id(s); "
            "give the real ones other ids, or set fleet.real_replaces_simulated = true")
    return both


def _without_real(scenario: Scenario, config: StartConfig) -> StartConfig:
    """Refuse an id both real and simulated, or (the scenario says so) drop the simulated one."""
    both = _real_and_simulated(scenario, config.ids)
    if not both:
        return config
    keep = ~np.isin(config.ids, both)
    return StartConfig(config.ids[keep], config.lat_deg[keep], config.lon_deg[keep], config.battery_frac[keep])


def fleet_params(scenario: Scenario) -> FleetParams:
    f, env = scenario.fleet, scenario.environment
    current = (
        UniformCurrent(env.current_east_mps, env.current_north_mps)
        if (env.current_east_mps, env.current_north_mps) != (0.0, 0.0) else NO_CURRENT
    )
    return FleetParams(
        theta=scenario.mission.theta,
        discharge_profile=f.discharge,
        charge_profile=f.charge,
        surfacing_time_s=f.surfacing_time_s,
        sinking_time_s=f.sinking_time_s,
        acoustic_range_m=f.acoustic_range_m,
        drift_half_width_m=f.drift_cm / 100.0,
        current=current,
        profile=f.profile,
        profile_ids=f.profiles,
        sleep_charge_profile=f.sleep_charge,
        wake_interval_s=f.wake_interval_s,
        awake_s=f.awake_s,
    )


def apad_params(scenario: Scenario, apad: ApadConfig | None = None) -> ApadParams:
    """The SITL parameters of one aPad of the scenario (default: the first)."""
    a = apad or scenario.apad
    return replace(
        ApadParams(), speed_max_mps=a.speed_mps, wp_radius_m=a.victory_radius_m, dock_reach_m=a.dock_reach_m,
        dock_time_s=a.dock_time_s, undock_time_s=a.undock_time_s, sysid_thismav=a.system_id,
        batt_capacity_wh=a.battery_wh, home_charge_w=a.home_charge_w,
    )


def sensor_field(scenario: Scenario, area: Area, frame: LocalFrame) -> SensorField:
    """Dummy values, or an anoxic patch a quarter of the area wide, centred in it, drifting east."""
    if scenario.fleet.sensor_field == "dummy":
        return DummySensors()
    local = area.to_local(frame)
    centre = local.representative_point()
    return AnoxicPatch(centre.x, centre.y, sigma_m=0.25 * local.area**0.5, velocity_east_mps=0.002)


def geofence_ring(area: Area, frame: LocalFrame, buffer_m: float) -> list[tuple[float, float]]:
    """The water area grown by `buffer_m`, as one (lat, lon) ring (several basins: their convex hull)."""
    local = area.to_local(frame).buffer(buffer_m)
    if local.geom_type != "Polygon":
        local = local.convex_hull
    x, y = local.exterior.xy
    lat, lon = frame.to_geodetic(np.asarray(x), np.asarray(y))
    return [(float(a), float(b)) for a, b in zip(lat, lon, strict=True)]




def planning_profile(scenario: Scenario) -> BehaviourProfile:
    """The behaviour profile the strategies plan with: the fleet's (fleet.profile), with the scenario's
    battery models. aMussels on another profile ([fleet.profiles], sleep orders) are planned as if on it."""
    table = fleet_params(scenario).profile_table
    return table.profiles[table.index(scenario.fleet.profile)]


def call_up_wait_s(scenario: Scenario, floor_s: float) -> float:
    """How long a call-up may take to float an aMussel, mission seconds: `floor_s`, or with aMussels on
    a wake schedule (fleet.profile, [fleet.profiles]) the longest wait for a wake (a call-up is held
    until it), its rise and a margin of as much again. Sleep orders given later are not foreseen."""
    table = fleet_params(scenario).profile_table
    used = {scenario.fleet.profile, *(name for name, _ in scenario.fleet.profiles)}
    gap_s = max((float(table.interval_s[table.index(n)]) for n in used), default=0.0) / scenario.mission.theta
    if gap_s == 0.0:
        return floor_s
    return max(floor_s, gap_s + 2 * scenario.fleet.surfacing_time_s)
