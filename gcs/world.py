"""Assemble a mission from a scenario: the aMussel fleet, the GCS link and API, and the aPad.

Headless runs (`lockstep_world`) put the SITL aPad, the fleet and the GCS on one virtual clock;
the aPad is reached over the in-memory transport with real MAVLink bytes both ways. The field
console builds the same pieces on a wall clock with a real transport (`field_world`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from apad_sitl.endpoint import SitlVehicle
from apad_sitl.params import ApadParams
from gcs.api import ApadApi, Location
from gcs.events import EventLog
from gcs.link import Link
from gcs.scenario import Scenario
from gcs.scenario_loop import EnergySharingLoop, LoopControl, LoopSettings
from mavlink_dialect import Codec, mavlink, memory_pair
from mavlink_dialect.clock import Clock, VirtualClock
from mussel_sim.comms import FLEET_COMPONENT_ID, FLEET_SYSTEM_ID, CommsConfig, FleetRunner
from mussel_sim.drift import NO_CURRENT, UniformCurrent
from mussel_sim.fleet import FleetParams, initial_state
from mussel_sim.geo import LocalFrame
from mussel_sim.placement import Area, load_area
from mussel_sim.sensors import AnoxicPatch, DummySensors, SensorField
from mussel_sim.startconfig import StartConfig, generate_start_config, load_start_config

# .tlog stamps of lockstep runs start here (2020-06-12 00:00 UTC), so logs are repeatable.
LOCKSTEP_EPOCH_US = 1_591_920_000_000_000
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
        self.link.close()
        self.events.close()


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
) -> World:
    """The GCS side of a mission: fleet, link and API on `clock`; transports are added by the caller."""
    rng = rng if rng is not None else np.random.default_rng(scenario.seed)
    area = load_area(scenario.fleet.area)
    config, frame = start_config(scenario, area, rng)
    params = fleet_params(scenario)
    if out_dir is not None:
        out_dir.mkdir(parents=True, exist_ok=True)
    link = Link(clock, tlog_path=out_dir / "gcs.tlog" if out_dir else None, tlog_epoch_us=tlog_epoch_us)
    events = EventLog(out_dir / "events.jsonl" if out_dir else None)
    port = link.attach(None)
    fleet = FleetRunner(
        initial_state(config, frame, params, clock.now_us), params, rng, frame,
        Codec(FLEET_SYSTEM_ID, FLEET_COMPONENT_ID), port.send_bytes, sensor_field(scenario, area, frame),
        CommsConfig(status_rate_hz=scenario.fleet.status_rate_hz, sensors_rate_hz=scenario.fleet.sensors_rate_hz),
        local=port.send_local,
    )
    port.handler = fleet.handle
    fleet.register(clock.scheduler, clock.now_us, end_us=clock.now_us + round(scenario.mission.duration_s * 1e6))
    api = ApadApi(link, clock, default_apad=scenario.apad.system_id)
    homes = {
        int(i): Location(float(lat), float(lon))
        for i, lat, lon in zip(config.ids, config.lat_deg, config.lon_deg, strict=True)
    }
    return World(scenario, clock, link, api, fleet, frame, config, homes, events)


def lockstep_world(scenario: Scenario, out_dir: Path | None = None) -> World:
    """Everything on one virtual clock; the aPad over an in-memory pair of real MAVLink bytes."""
    clock = VirtualClock()
    world = build_world(scenario, clock, out_dir, LOCKSTEP_EPOCH_US)
    gcs_end, apad_end = memory_pair("apad")
    a = scenario.apad
    vehicle = SitlVehicle(
        apad_end, apad_params(scenario), a.home_lat_deg, a.home_lon_deg, system_id=a.system_id,
        current_mps=(scenario.environment.current_east_mps, scenario.environment.current_north_mps),
        log_dir=out_dir, log_epoch_us=LOCKSTEP_EPOCH_US,
    )
    vehicle.attach(clock.scheduler, clock.now_us)
    world.link.add_transport(gcs_end)
    world.vehicle = vehicle
    return world
