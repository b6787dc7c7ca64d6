"""LocalFrame's cheap pipeline is the operation `Transformer.from_crs` builds, bit for bit."""

from __future__ import annotations

import numpy as np
from pyproj import Transformer

from mussel_sim.geo import LocalFrame


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
