"""Geodesy for the models: a local metric frame around an origin, and geodesic distances.

Positions inside the models are metres east/north of an origin (x_m, y_m), so physics is plain
vector arithmetic; MAVLink carries WGS84 degrees. pyproj does every conversion: an azimuthal
equidistant projection at the origin matches the WGS84 geodesic to the millimetre over the
few kilometres a mission covers (NOTES.md).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pyproj import Geod, Transformer

WGS84 = Geod(ellps="WGS84")


@dataclass(frozen=True)
class LocalFrame:
    """East/north metres around (origin_lat_deg, origin_lon_deg)."""

    origin_lat_deg: float
    origin_lon_deg: float
    _fwd: Transformer = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        proj = (
            f"+proj=aeqd +lat_0={self.origin_lat_deg} +lon_0={self.origin_lon_deg} "
            "+datum=WGS84 +units=m"
        )
        object.__setattr__(self, "_fwd", Transformer.from_crs("EPSG:4326", proj, always_xy=True))

    def to_local(self, lat_deg: ArrayLike, lon_deg: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(x_m east, y_m north) of WGS84 points; arrays in, arrays of the same shape out."""
        x, y = self._fwd.transform(np.asarray(lon_deg, float), np.asarray(lat_deg, float))
        return np.asarray(x, float), np.asarray(y, float)

    def to_geodetic(self, x_m: ArrayLike, y_m: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(lat_deg, lon_deg) of local points."""
        lon, lat = self._fwd.transform(np.asarray(x_m, float), np.asarray(y_m, float), direction="INVERSE")
        return np.asarray(lat, float), np.asarray(lon, float)


def distance_m(
    lat1_deg: ArrayLike, lon1_deg: ArrayLike, lat2_deg: ArrayLike, lon2_deg: ArrayLike
) -> NDArray[np.float64]:
    """Geodesic distance on the WGS84 ellipsoid, vectorised."""
    _, _, dist = WGS84.inv(
        np.asarray(lon1_deg, float), np.asarray(lat1_deg, float),
        np.asarray(lon2_deg, float), np.asarray(lat2_deg, float),
    )
    return np.asarray(dist, float)


def planar_distance_m(
    x1_m: ArrayLike, y1_m: ArrayLike, x2_m: ArrayLike, y2_m: ArrayLike
) -> NDArray[np.float64]:
    """Distance between points of one `LocalFrame`, vectorised with numpy broadcasting.

    The frame is azimuthal equidistant, so its scale error a distance r from the origin is about
    r^2 / (6 R^2): 1e-7 at 5 km, i.e. 0.01 mm over a 100 m acoustic range. That is why the
    models compare ranges in the plane (cheap, per step) and keep `distance_m` for reporting.
    """
    dx = np.asarray(x2_m, float) - np.asarray(x1_m, float)
    dy = np.asarray(y2_m, float) - np.asarray(y1_m, float)
    return np.hypot(dx, dy)


# Metres per degree of latitude, WGS84, at mid latitudes; for pictures only (see `flat_m`).
M_PER_DEG_LAT = 110_574.0


def flat_m(
    lat_deg: ArrayLike, lon_deg: ArrayLike, lat0_deg: float, lon0_deg: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(x_m east, y_m north) by the equirectangular approximation around (lat0, lon0).

    For drawing maps and plots: cheap per frame and good to a fraction of a percent over a bay.
    Anything that decides (ranges, costs, geofences) uses `LocalFrame` or `distance_m`.
    """
    kx = M_PER_DEG_LAT * np.cos(np.radians(lat0_deg))
    return (np.asarray(lon_deg, float) - lon0_deg) * kx, (np.asarray(lat_deg, float) - lat0_deg) * M_PER_DEG_LAT

