"""Horizontal motion of free aMussels: a water current field plus the paper's random drift.

Positions are metres east/north in the scenario's `LocalFrame`. Currents are m/s (east, north)
and act over mission time (`current * dt_s`); the paper ran without current and with a random
drift of U(-0.5, 0.5) cm per axis every second (section V-A) for drift while sinking/rising and
localisation noise.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

# Paper, section V-A: U(-0.5, 0.5) cm per axis per 1 s step.
PAPER_DRIFT_HALF_WIDTH_M = 0.005


class CurrentField(Protocol):
    def velocity_mps(
        self, x_m: NDArray[np.float64], y_m: NDArray[np.float64], t_s: float
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(east, north) current [m/s] at points `(n,)` at mission time `t_s`."""
        ...


@dataclass(frozen=True)
class NoCurrent:
    def velocity_mps(
        self, x_m: NDArray[np.float64], y_m: NDArray[np.float64], t_s: float
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        zero = np.zeros_like(x_m)
        return zero, zero


@dataclass(frozen=True)
class UniformCurrent:
    east_mps: float
    north_mps: float

    def velocity_mps(
        self, x_m: NDArray[np.float64], y_m: NDArray[np.float64], t_s: float
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        return np.full_like(x_m, self.east_mps), np.full_like(x_m, self.north_mps)


@dataclass(frozen=True, eq=False)
class GriddedCurrent:
    """Current on a regular grid of the local frame, bilinearly interpolated.

    Node (j, i) sits at (x0_m + i * dx_m, y0_m + j * dy_m); east_mps / north_mps are `(ny, nx)`.
    Outside the grid the nearest edge value holds (no extrapolation).
    """

    x0_m: float
    y0_m: float
    dx_m: float
    dy_m: float
    east_mps: NDArray[np.float64]
    north_mps: NDArray[np.float64]
    _stack: NDArray[np.float64] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        east = np.asarray(self.east_mps, float)
        north = np.asarray(self.north_mps, float)
        if east.ndim != 2 or east.shape != north.shape or min(east.shape) < 2:
            raise ValueError(f"current grids must be equal (ny, nx) >= (2, 2), got {east.shape}, {north.shape}")
        if self.dx_m <= 0 or self.dy_m <= 0:
            raise ValueError("grid spacing must be positive")
        object.__setattr__(self, "east_mps", east)
        object.__setattr__(self, "north_mps", north)
        object.__setattr__(self, "_stack", np.stack([east, north]))

    @classmethod
    def from_npz(cls, path: str | Path) -> GriddedCurrent:
        """Load arrays x0_m, y0_m, dx_m, dy_m (scalars), east_mps, north_mps `(ny, nx)`."""
        with np.load(path) as z:
            return cls(
                float(z["x0_m"]), float(z["y0_m"]), float(z["dx_m"]), float(z["dy_m"]),
                z["east_mps"], z["north_mps"],
            )

    def save_npz(self, path: str | Path) -> None:
        np.savez(
            path, x0_m=self.x0_m, y0_m=self.y0_m, dx_m=self.dx_m, dy_m=self.dy_m,
            east_mps=self.east_mps, north_mps=self.north_mps,
        )

    def velocity_mps(
        self, x_m: NDArray[np.float64], y_m: NDArray[np.float64], t_s: float
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        ny, nx = self.east_mps.shape
        fx = np.clip((np.asarray(x_m, float) - self.x0_m) / self.dx_m, 0.0, nx - 1.0)
        fy = np.clip((np.asarray(y_m, float) - self.y0_m) / self.dy_m, 0.0, ny - 1.0)
        # Lower cell corner, kept one short of the last node so i + 1 is always valid.
        i = np.minimum(fx.astype(np.intp), nx - 2)
        j = np.minimum(fy.astype(np.intp), ny - 2)
        wx = fx - i
        wy = fy - j
        g = self._stack
        v00 = g[:, j, i]
        v01 = g[:, j, i + 1]
        v10 = g[:, j + 1, i]
        v11 = g[:, j + 1, i + 1]
        out = (v00 * (1 - wx) + v01 * wx) * (1 - wy) + (v10 * (1 - wx) + v11 * wx) * wy
        return out[0], out[1]


NO_CURRENT = NoCurrent()


def random_drift_m(
    rng: np.random.Generator, n: int, half_width_m: float = PAPER_DRIFT_HALF_WIDTH_M
) -> NDArray[np.float64]:
    """Per-axis random displacement `(2, n)` (east row, north row), U(-half_width, half_width)."""
    return rng.uniform(-half_width_m, half_width_m, size=(2, n))


DRIFT_BLOCK_STEPS = 1024  # steps of draws made at once by `summed_drift_m`: bounded memory over a long step


def summed_drift_m(
    rng: np.random.Generator, n: int, half_width_m: float, steps: int
) -> NDArray[np.float64]:
    """`random_drift_m` of `steps` steps in a row, summed `(2, n)`: the draws of so many one-step calls in
    their order (a `Generator` fills an array in the order it would fill the calls' arrays), so a long step
    leaves each aMussel where that many steps leave it, to float rounding, and the stream where they leave it."""
    total = np.zeros((2, n))
    for start in range(0, steps, DRIFT_BLOCK_STEPS):
        block = min(DRIFT_BLOCK_STEPS, steps - start)
        total += rng.uniform(-half_width_m, half_width_m, size=(block, 2, n)).sum(axis=0)
    return total
