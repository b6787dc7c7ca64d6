"""Assemble a mission from a scenario: the aMussel fleet, the GCS link and API, and the aPad.

Headless runs (`lockstep_world`) put the SITL aPad, the fleet and the GCS on one virtual clock;
the aPad is reached over the in-memory transport with real MAVLink bytes both ways. The field
console builds the same pieces on a wall clock with a real transport (`field_world`).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from apad_sitl.endpoint import SitlVehicle
from apad_sitl.params import ApadParams
from gcs.api import ApadApi, Location
from gcs.link.faultproxy import FaultProxy, LinkFaults
from gcs.link.router import Link
from gcs.mission.loop import EnergySharingLoop, LoopControl, LoopSettings
from gcs.mission.scenario import Scenario, ScenarioError
from gcs.records.events import EventLog
from mavlink_dialect import Codec, mavlink, memory_pair, signing
from mavlink_dialect.transport import UdpTransport
from missiontime import Clock, VirtualClock
from mussel_sim.comms import FLEET_COMPONENT_ID, FLEET_SYSTEM_ID, CommsConfig, FleetRunner
from mussel_sim.drift import NO_CURRENT, UniformCurrent
from mussel_sim.fleet import FleetParams, initial_state
from mussel_sim.geo import LocalFrame
from mussel_sim.placement import Area, load_area
from mussel_sim.sensors import AnoxicPatch, DummySensors, SensorField
from mussel_sim.startconfig import StartConfig, generate_start_config, load_start_config

# .tlog stamps of lockstep runs start here (2020-06-12 00:00 UTC), so logs are repeatable.
LOCKSTEP_EPOCH_US = 1_591_920_000_000_000
# The geofence is the scenario's water area grown by this much (GPS error, drift of the aMussels).
GEOFENCE_BUFFER_M = 10.0
GCS_SIGNING_LINK_ID = 1


@dataclass(frozen=True)
class LinkOptions:
    """How the GCS reaches the embedded aPad in lockstep: in memory (default) or over real UDP via a fault proxy."""

    faults: LinkFaults | None = None  # not None: real UDP sockets through a FaultProxy
    signing_key: bytes | None = None  # MAVLink 2 signing on both ends
    geofence_buffer_m: float | None = GEOFENCE_BUFFER_M  # None: no geofence
# What the mission loop needs from the aPad, requested like any GCS does (SET_MESSAGE_INTERVAL).
# Slot and primitive changes are also sent the moment they happen, so slow periodic copies do.
MISSION_TELEMETRY_HZ = {
    mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 2.0,
    mavlink.MAVLINK_MSG_ID_PRIMITIVE_STATUS: 1.0,
    mavlink.MAVLINK_MSG_ID_DOCK_SLOT_STATUS: 0.2,
    mavlink.MAVLINK_MSG_ID_BATTERY_STATUS: 0.2,
}


@dataclass
class World:
    scenario: Scenario
    clock: Clock
    link: Link
    api: ApadApi
    fleet: FleetRunner
    frame: LocalFrame
    start: StartConfig
    homes: dict[int, Location]  # where each aMussel started, and goes back to
    events: EventLog
    vehicle: SitlVehicle | None = None  # the embedded SITL aPad, if any
    proxy: FaultProxy | None = None  # the fault-injection proxy between GCS and aPad, if any
    geofence_deg: list[tuple[float, float]] = field(default_factory=list)  # (lat, lon) ring; empty: none

    def mission_loop(self, control: LoopControl | None = None) -> EnergySharingLoop:
        s = self.scenario
        settings = LoopSettings(
            mission=s.mission,
            acoustic_range_m=s.fleet.acoustic_range_m,
            dock_reach_m=s.apad.dock_reach_m,
            battery_end_v=s.apad.battery_end_v,
        )
        return EnergySharingLoop(self.api, self.clock, settings, self.homes, s.apad.system_id, self.events, control)

    def close(self) -> None:
        if self.vehicle is not None:
            self.vehicle.close()
        if self.proxy is not None:
            self.proxy.close()
        self.link.close()
        self.events.close()


def check_inputs(scenario: Scenario) -> None:
    """Read the scenario's area and start configuration now, so a bad file is one `ScenarioError` line
    (file: what is wrong) before any mission starts, never a traceback from the middle of one."""
    files = [("area", scenario.fleet.area)]
    if scenario.fleet.start_config is not None:
        files.append(("start configuration", scenario.fleet.start_config))
    for what, path in files:
        try:
            if what == "area":
                area = load_area(path)
                if not area.geometry.is_valid:
                    raise ValueError("the polygon is not valid (self-intersecting or degenerate)")
                lon_min, lat_min, lon_max, lat_max = area.geometry.bounds
                if not (-90 <= lat_min <= lat_max <= 90 and -180 <= lon_min <= lon_max <= 180):
                    raise ValueError("coordinates are not WGS84 degrees [lon, lat] (GeoJSON order)")
            else:
                config = load_start_config(path)
                if config.n != scenario.fleet.count:
                    raise ValueError(f"holds {config.n} aMussels, the scenario says {scenario.fleet.count}")
        except OSError as exc:
            raise ScenarioError(f"{path}: cannot read the {what}: {exc.strerror or exc}") from None
        except json.JSONDecodeError as exc:
            raise ScenarioError(f"{path}: the {what} is not JSON: {exc.msg} (line {exc.lineno})") from None
        except (ValueError, KeyError, TypeError, IndexError, AttributeError) as exc:
            detail = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise ScenarioError(f"{path}: bad {what}: {detail}") from None


def start_config(scenario: Scenario, area: Area, rng: np.random.Generator) -> tuple[StartConfig, LocalFrame]:
    """The scenario's saved start configuration, or one drawn from its area with the run's rng."""
    frame = area.frame()
    if scenario.fleet.start_config is not None:
        config = load_start_config(scenario.fleet.start_config)
        if config.n != scenario.fleet.count:
            raise ValueError(
                f"{scenario.fleet.start_config}: holds {config.n} aMussels, the scenario says {scenario.fleet.count}"
            )
        return config, frame
    battery = (scenario.fleet.battery_min, scenario.fleet.battery_max)
    return generate_start_config(area, scenario.fleet.count, frame, rng, battery_range=battery), frame


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
    )


def apad_params(scenario: Scenario) -> ApadParams:
    a = scenario.apad
    return replace(
        ApadParams(), speed_max_mps=a.speed_mps, wp_radius_m=a.victory_radius_m, dock_reach_m=a.dock_reach_m,
        dock_time_s=a.dock_time_s, undock_time_s=a.undock_time_s, sysid_thismav=a.system_id,
    )


def sensor_field(scenario: Scenario, area: Area, frame: LocalFrame) -> SensorField:
    """Dummy values, or an anoxic patch a quarter of the area wide, centred in it, drifting east."""
    if scenario.fleet.sensor_field == "dummy":
        return DummySensors()
    local = area.to_local(frame)
    centre = local.representative_point()
    return AnoxicPatch(centre.x, centre.y, sigma_m=0.25 * local.area**0.5, velocity_east_mps=0.002)


def build_world(
    scenario: Scenario,
    clock: Clock,
    out_dir: Path | None,
    tlog_epoch_us: int,
    rng: np.random.Generator | None = None,
    mission_start_us: int | None = None,
    append_logs: bool = False,
    geofence_buffer_m: float | None = None,
) -> World:
    """The GCS side of a mission: fleet, link and API on `clock`; transports are added by the caller.

    `mission_start_us` is when the mission began (default: now; a resumed mission began earlier);
    `append_logs` continues the folder's logs instead of starting them afresh.
    """
    rng = rng if rng is not None else np.random.default_rng(scenario.seed)
    start_us = clock.now_us if mission_start_us is None else mission_start_us
    area = load_area(scenario.fleet.area)
    config, frame = start_config(scenario, area, rng)
    params = fleet_params(scenario)
    if out_dir is not None:
        out_dir.mkdir(parents=True, exist_ok=True)
    link = Link(clock, tlog_path=out_dir / "gcs.tlog" if out_dir else None, tlog_epoch_us=tlog_epoch_us,
                append=append_logs)
    events = EventLog(out_dir / "events.jsonl" if out_dir else None, append=append_logs)
    port = link.attach(None)
    fleet = FleetRunner(
        initial_state(config, frame, params, clock.now_us), params, rng, frame,
        Codec(FLEET_SYSTEM_ID, FLEET_COMPONENT_ID), port.send_bytes, sensor_field(scenario, area, frame),
        CommsConfig(status_rate_hz=scenario.fleet.status_rate_hz, sensors_rate_hz=scenario.fleet.sensors_rate_hz),
        local=port.send_local,
    )
    port.handler = fleet.handle
    fleet.register(clock.scheduler, clock.now_us, end_us=start_us + round(scenario.mission.duration_s * 1e6))
    fence = geofence_ring(area, frame, geofence_buffer_m) if geofence_buffer_m is not None else []
    api = ApadApi(link, clock, default_apad=scenario.apad.system_id, geofence_deg=fence or None)
    homes = {
        int(i): Location(float(lat), float(lon))
        for i, lat, lon in zip(config.ids, config.lat_deg, config.lon_deg, strict=True)
    }
    return World(scenario, clock, link, api, fleet, frame, config, homes, events, geofence_deg=fence)


def geofence_ring(area: Area, frame: LocalFrame, buffer_m: float) -> list[tuple[float, float]]:
    """The water area grown by `buffer_m`, as one (lat, lon) ring (several basins: their convex hull)."""
    local = area.to_local(frame).buffer(buffer_m)
    if local.geom_type != "Polygon":
        local = local.convex_hull
    x, y = local.exterior.xy
    lat, lon = frame.to_geodetic(np.asarray(x), np.asarray(y))
    return [(float(a), float(b)) for a, b in zip(lat, lon, strict=True)]


def lockstep_world(
    scenario: Scenario, out_dir: Path | None = None, options: LinkOptions | None = None,
    start_us: int = 0, append_logs: bool = False,
) -> World:
    """Everything on one virtual clock; the aPad over an in-memory pair of real MAVLink bytes, or
    over real UDP sockets through a `FaultProxy` whose delays run on the same virtual clock.

    `start_us` > 0 starts the clock later (a resumed mission; the mission itself began at 0).
    """
    options = options or LinkOptions()
    clock = VirtualClock(start_us=start_us)
    world = build_world(scenario, clock, out_dir, LOCKSTEP_EPOCH_US, mission_start_us=0, append_logs=append_logs,
                        geofence_buffer_m=options.geofence_buffer_m)
    a = scenario.apad
    proxy = None
    if options.faults is None:
        gcs_end, apad_end = memory_pair("apad")
    else:
        apad_end = UdpTransport("127.0.0.1", 0, listen=True)
        proxy = FaultProxy(clock, ("127.0.0.1", apad_end.local_port), options.faults)
        gcs_end = UdpTransport("127.0.0.1", proxy.listen_port, listen=False)
    vehicle = SitlVehicle(
        apad_end, apad_params(scenario), a.home_lat_deg, a.home_lon_deg, system_id=a.system_id,
        current_mps=(scenario.environment.current_east_mps, scenario.environment.current_north_mps),
        log_dir=out_dir, log_epoch_us=LOCKSTEP_EPOCH_US, signing_key=options.signing_key,
        geofence_deg=world.geofence_deg or None, log_append=append_logs,
    )
    vehicle.attach(clock.scheduler, clock.now_us)
    world.link.add_transport(gcs_end)
    if options.signing_key is not None:
        world.link.enable_signing(options.signing_key, GCS_SIGNING_LINK_ID,
                                  lambda: signing.timestamp_ticks(LOCKSTEP_EPOCH_US, clock.now_us))
    world.vehicle = vehicle
    world.proxy = proxy
    return world
