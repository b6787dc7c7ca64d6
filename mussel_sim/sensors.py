"""Simulated aMussel sensors: dissolved oxygen, temperature, pressure, turbidity, vectorised.

A sensor field is a pure function of positions (local metres), depth and mission time. Pressure
always follows depth (hydrostatic); the other three come from the scenario's field: `DummySensors`
(constants, for runs that only care about energy) or `AnoxicPatch` (the phenomenon the aMussels
monitor in Venice: a localised drop of dissolved oxygen, here a Gaussian depression whose centre
moves with a constant velocity).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

SURFACE_PRESSURE_HPA = 1013.25  # standard atmosphere
SEAWATER_DENSITY_KG_M3 = 1025.0
GRAVITY_MPS2 = 9.80665
PA_PER_HPA = 100.0


@dataclass(frozen=True, eq=False)
class SensorReadings:
    """One reading per aMussel, each `(n,)`."""

    dissolved_oxygen_mg_l: NDArray[np.float64]
    temperature_degc: NDArray[np.float64]
    pressure_hpa: NDArray[np.float64]
    turbidity_ntu: NDArray[np.float64]


def pressure_hpa(depth_m: NDArray[np.float64]) -> NDArray[np.float64]:
    """Absolute pressure at `depth_m` (positive down): atmosphere plus the water column."""
    return SURFACE_PRESSURE_HPA + SEAWATER_DENSITY_KG_M3 * GRAVITY_MPS2 * np.asarray(depth_m, float) / PA_PER_HPA


class SensorField(Protocol):
    def sample(
        self, x_m: NDArray[np.float64], y_m: NDArray[np.float64], depth_m: NDArray[np.float64], t_s: float
    ) -> SensorReadings: ...


@dataclass(frozen=True)
class DummySensors:
    dissolved_oxygen_mg_l: float = 8.0
    temperature_degc: float = 18.0
    turbidity_ntu: float = 2.0

    def sample(
        self, x_m: NDArray[np.float64], y_m: NDArray[np.float64], depth_m: NDArray[np.float64], t_s: float
    ) -> SensorReadings:
        shape = np.shape(x_m)
        return SensorReadings(
            np.full(shape, self.dissolved_oxygen_mg_l),
            np.full(shape, self.temperature_degc),
            pressure_hpa(depth_m),
            np.full(shape, self.turbidity_ntu),
        )


@dataclass(frozen=True)
class AnoxicPatch:
    """An oxygen depression of Gaussian shape drifting at a constant velocity.

    DO = background - depression * g, turbidity = background + excess * g, with
    g = exp(-r^2 / (2 sigma^2)), r the distance to the centre at time t. Temperature falls
    linearly with depth. Centre at (centre_x_m, centre_y_m) at t = 0, mission time.
    """

    centre_x_m: float
    centre_y_m: float
    sigma_m: float
    velocity_east_mps: float = 0.0
    velocity_north_mps: float = 0.0
    background_oxygen_mg_l: float = 8.0
    depression_mg_l: float = 7.0
    surface_temperature_degc: float = 20.0
    temperature_lapse_degc_per_m: float = 0.3
    background_turbidity_ntu: float = 2.0
    patch_turbidity_ntu: float = 10.0

    def centre_m(self, t_s: float) -> tuple[float, float]:
        return (
            self.centre_x_m + self.velocity_east_mps * t_s,
            self.centre_y_m + self.velocity_north_mps * t_s,
        )

    def sample(
        self, x_m: NDArray[np.float64], y_m: NDArray[np.float64], depth_m: NDArray[np.float64], t_s: float
    ) -> SensorReadings:
        cx, cy = self.centre_m(t_s)
        r2 = (np.asarray(x_m, float) - cx) ** 2 + (np.asarray(y_m, float) - cy) ** 2
        g = np.exp(-r2 / (2.0 * self.sigma_m**2))
        depth = np.asarray(depth_m, float)
        return SensorReadings(
            self.background_oxygen_mg_l - self.depression_mg_l * g,
            self.surface_temperature_degc - self.temperature_lapse_degc_per_m * depth,
            pressure_hpa(depth),
            self.background_turbidity_ntu + self.patch_turbidity_ntu * g,
        )
