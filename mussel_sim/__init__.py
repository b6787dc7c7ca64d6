"""aMussel fleet simulator: battery, positions and drift, sensors, states, comms. Pure models take dt.

The model is `fleet.step(state, inputs, params, rng, dt_s) -> (state, events)` over numpy arrays;
`comms.FleetRunner` is the edge that speaks MAVLink for it.
"""

from mussel_sim.battery import (
    CHARGE_PROFILES,
    DISCHARGE_PROFILES,
    ChargeProfile,
    DischargeProfile,
    step_battery,
    to_millivolts,
)
from mussel_sim.behaviour import (
    BEHAVIOURS,
    BehaviourProfile,
    ProfileTable,
    duty_cycle_rate_per_min,
    sleep_order_problem,
)
from mussel_sim.comms import FLEET_COMPONENT_ID, FLEET_SYSTEM_ID, CommsConfig, FleetRunner, MusselIdCollision
from mussel_sim.drift import GriddedCurrent, NoCurrent, UniformCurrent, random_drift_m
from mussel_sim.fleet import step
from mussel_sim.fleet_state import (
    FleetInputs,
    FleetParams,
    FleetState,
    StepEvents,
    initial_state,
    start_config_of,
    state_from_arrays,
)
from mussel_sim.geo import LocalFrame, distance_m, planar_distance_m
from mussel_sim.placement import Area, area_from_geojson, load_area, place_uniform
from mussel_sim.recorder import Recorder, UptimeSummary
from mussel_sim.sensors import AnoxicPatch, DummySensors, SensorReadings
from mussel_sim.startconfig import (
    StartConfig,
    generate_start_config,
    load_start_config,
    save_start_config,
    start_config_from_positions,
)
from mussel_sim.wake import next_wake_s

__all__ = [
    "BEHAVIOURS",
    "CHARGE_PROFILES",
    "DISCHARGE_PROFILES",
    "FLEET_COMPONENT_ID",
    "FLEET_SYSTEM_ID",
    "AnoxicPatch",
    "Area",
    "BehaviourProfile",
    "ChargeProfile",
    "CommsConfig",
    "DischargeProfile",
    "DummySensors",
    "FleetInputs",
    "FleetParams",
    "FleetRunner",
    "FleetState",
    "GriddedCurrent",
    "LocalFrame",
    "MusselIdCollision",
    "NoCurrent",
    "ProfileTable",
    "Recorder",
    "SensorReadings",
    "StartConfig",
    "StepEvents",
    "UniformCurrent",
    "UptimeSummary",
    "area_from_geojson",
    "distance_m",
    "duty_cycle_rate_per_min",
    "generate_start_config",
    "initial_state",
    "load_area",
    "load_start_config",
    "next_wake_s",
    "place_uniform",
    "planar_distance_m",
    "random_drift_m",
    "save_start_config",
    "sleep_order_problem",
    "start_config_from_positions",
    "start_config_of",
    "state_from_arrays",
    "step",
    "step_battery",
    "to_millivolts",
]
