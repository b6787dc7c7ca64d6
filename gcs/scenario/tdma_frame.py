"""A scenario's TDMA frame: its aMussels and aPads, and the largest range over its area (the area's
diameter, with the seabed's depth on top: a node on the seabed to one at the surface across it)."""

from __future__ import annotations

import numpy as np
import shapely

from acoustic.tdma import TdmaFrame, largest_range_m, tdma_frame
from gcs.scenario.model_params import fleet_params, start_config
from gcs.scenario.reader import Scenario
from mussel_sim.placement import load_area


def area_range_m(scenario: Scenario) -> float:
    """The largest distance a packet crosses in the scenario's water (metres)."""
    area = load_area(scenario.fleet.area)
    vertices = shapely.get_coordinates(area.to_local(area.frame()))
    return largest_range_m(vertices, depth_m=fleet_params(scenario).seabed_depth_m)


def scenario_frame(scenario: Scenario) -> TdmaFrame:
    """The frame of the scenario's fleet (its start configuration's ids, or those its seed draws) and aPads."""
    area = load_area(scenario.fleet.area)
    config, _ = start_config(scenario, area, np.random.default_rng(scenario.seed))
    return tdma_frame(config.ids, [a.system_id for a in scenario.apads], area_range_m(scenario), scenario.acoustic)
