"""Geodesy for the models: a local metric frame around an origin, and geodesic distances.

Positions inside the models are metres east/north of an origin (x_m, y_m), so physics is plain
vector arithmetic; MAVLink carries WGS84 degrees. pyproj does every conversion: an azimuthal
equidistant projection at the origin matches the WGS84 geodesic to the millimetre over the
few kilometres a mission covers (NOTES.md).
"""

from __future__ import annotations

import functools
import re
import warnings
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pyproj import CRS, Geod, Transformer
from pyproj.enums import TransformDirection

WGS84 = Geod(ellps="WGS84")
_SCALARS = (int, float, np.integer, np.floating)  # one point: pyproj is 4x cheaper on floats than arrays
_INVERSE = TransformDirection.INVERSE  # the enum itself: pyproj parses the string "INVERSE" at every call (1.5 us)


def aeqd_transformer(lat_deg: float, lon_deg: float) -> Transformer:
    """WGS84 degrees (lon, lat) <-> aeqd metres at the origin: what `Transformer.from_crs("EPSG:4326",
    "+proj=aeqd ... +datum=WGS84", always_xy=True)` builds, bit for bit, in 0.3 ms instead of 5-15.

    from_crs searches PROJ's database for the operation and instantiates the one it finds from its
    PROJ string, whose origin is rounded to 15 digits; the CRS's own PROJ string carries the same
    rounding, so the pipeline is built from it (tests/unit/test_geo.py checks it against from_crs).
    A swarm makes a frame per Go To (swarm separation), so this was 6 % of a bay120 run.
    """
    crs = CRS(f"+proj=aeqd +lat_0={lat_deg} +lon_0={lon_deg} +datum=WGS84 +units=m")
    with warnings.catch_warnings():  # "you will likely lose information": not for a plain aeqd
        warnings.simplefilter("ignore", UserWarning)
        origin = dict(re.findall(r"\+(lat_0|lon_0)=(\S+)", crs.to_proj4()))
    return Transformer.from_pipeline(
        "+proj=pipeline +step +proj=unitconvert +xy_in=deg +xy_out=rad "
        f"+step +proj=aeqd +lat_0={origin['lat_0']} +lon_0={origin['lon_0']} +x_0=0 +y_0=0 +ellps=WGS84"
    )


@dataclass(frozen=True)
class LocalFrame:
    """East/north metres around (origin_lat_deg, origin_lon_deg)."""

    origin_lat_deg: float
    origin_lon_deg: float
    _fwd: Transformer = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_fwd", aeqd_transformer(self.origin_lat_deg, self.origin_lon_deg))

    def to_local(self, lat_deg: ArrayLike, lon_deg: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(x_m east, y_m north) of WGS84 points; arrays in, arrays of the same shape out."""
        if isinstance(lat_deg, _SCALARS) and isinstance(lon_deg, _SCALARS):
            x, y = self._fwd.transform(float(lon_deg), float(lat_deg))
        else:
            x, y = self._fwd.transform(np.asarray(lon_deg, float), np.asarray(lat_deg, float))
        return np.asarray(x, float), np.asarray(y, float)

    def to_geodetic(self, x_m: ArrayLike, y_m: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(lat_deg, lon_deg) of local points."""
        if isinstance(x_m, _SCALARS) and isinstance(y_m, _SCALARS):
            lon, lat = self._fwd.transform(float(x_m), float(y_m), direction=_INVERSE)
        else:
            lon, lat = self._fwd.transform(np.asarray(x_m, float), np.asarray(y_m, float), direction=_INVERSE)
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


@functools.lru_cache(maxsize=4096)
def pair_distance_m(lat1_deg: float, lon1_deg: float, lat2_deg: float, lon2_deg: float) -> float:
    """`distance_m` of one pair, remembered: a planner asks for the same pairs again and again (an aPad
    holding, a sleeper's last fix), and each call into the geodesic costs tens of microseconds."""
    return float(distance_m(lat1_deg, lon1_deg, lat2_deg, lon2_deg))


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

