"""LocalFrame's cheap pipeline is the operation `Transformer.from_crs` builds, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
from pyproj import Transformer

from apad_sitl.geofence import KNOWN_FIXES, Geofence
from gcs.strategies.routing import metres_matrix
from mussel_sim.geo import LocalFrame, distance_m, pair_distance_m


def test_local_frame_matches_from_crs_bit_for_bit() -> None:
    rng = np.random.default_rng(2)
    for k in range(150):
        if k % 2:  # anywhere, full-precision origins (from_crs rounds them to 15 digits)
            lat, lon = float(rng.uniform(-85, 85)), float(rng.uniform(-180, 180))
        else:  # aPad positions in a bay, as route checks make them
            lat, lon = 43.939 + float(rng.uniform(-0.01, 0.01)), 15.44 + float(rng.uniform(-0.01, 0.01))
        ref = Transformer.from_crs(
            "EPSG:4326", f"+proj=aeqd +lat_0={lat} +lon_0={lon} +datum=WGS84 +units=m", always_xy=True)
        frame = LocalFrame(lat, lon)
        la, lo = lat + rng.uniform(-0.05, 0.05, 50), lon + rng.uniform(-0.05, 0.05, 50)
        x, y = frame.to_local(la, lo)
        rx, ry = ref.transform(lo, la)
        assert np.array_equal(x, rx) and np.array_equal(y, ry)
        back_lat, back_lon = frame.to_geodetic(x * 1.5, y)
        rlon, rlat = ref.transform(x * 1.5, y, direction="INVERSE")
        assert np.array_equal(back_lat, rlat) and np.array_equal(back_lon, rlon)
        sx, sy = frame.to_local(float(la[0]), float(lo[0]))  # the scalar path
        assert sx.shape == () and (float(sx), float(sy)) == (rx[0], ry[0])
        slat, slon = frame.to_geodetic(np.float64(x[1] * 1.5), float(y[1]))
        assert (float(slat), float(slon)) == (rlat[1], rlon[1])


# --- remembered answers: the planner asks the same questions while it waits ---------------------

def test_remembered_distances_and_matrices_are_the_geodesics_own() -> None:
    rng = np.random.default_rng(7)
    lat, lon = 43.93 + rng.random(9) * 0.01, 15.43 + rng.random(9) * 0.01
    fresh = np.array([[float(distance_m(a, b, c, d)) for c, d in zip(lat, lon, strict=True)]
                      for a, b in zip(lat, lon, strict=True)])
    for _ in range(2):  # the first call computes, the second remembers: the same answer both times
        metres = metres_matrix(lat.copy(), lon.copy())
        assert np.array_equal(metres, fresh)
        assert pair_distance_m(float(lat[0]), float(lon[0]), float(lat[1]), float(lon[1])) == fresh[0, 1]
    with pytest.raises(ValueError):
        metres[0, 1] = 0.0  # shared between callers: nobody may change it
    shifted = lon + 0.001  # the same latitudes, other longitudes: another answer, not the one remembered
    points = list(zip(lat, shifted, strict=True))
    want = np.array([[float(distance_m(a, b, c, d)) for c, d in points] for a, b in points])
    assert np.array_equal(metres_matrix(lat, shifted), want)
    assert pair_distance_m(float(lat[0]), float(shifted[0]), float(lat[1]), float(lon[1])) == float(
        distance_m(lat[0], shifted[0], lat[1], lon[1]))


def test_a_geofence_remembers_its_answers_and_forgets_them_at_its_bound() -> None:
    frame = LocalFrame(43.94, 15.44)
    square = [frame.to_geodetic(x, y) for x, y in ((0.0, 0.0), (100.0, 0.0), (100.0, 100.0), (0.0, 100.0))]
    fence = Geofence.of([(float(a), float(b)) for a, b in square], frame)
    rng = np.random.default_rng(3)
    points = [tuple(map(float, frame.to_geodetic(x, y))) for x, y in rng.uniform(-50.0, 150.0, (KNOWN_FIXES + 50, 2))]
    for lat, lon in points:
        x, y = frame.to_local(lat, lon)
        want = 0.0 <= float(x) <= 100.0 and 0.0 <= float(y) <= 100.0
        assert fence.contains_deg(lat, lon) == want
        assert fence.contains_deg(lat, lon) == want  # asked again: remembered
    assert 0 < fence.remembered <= KNOWN_FIXES  # bounded however long the mission
