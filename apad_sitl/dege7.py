"""Local metres -> degE7, the way the aPad's telemetry carries positions, remembering the last point.

Most sends repeat the point before (a hull at rest, a target held), so the conversion runs only when
the point moves. A Go To `remember`s its target as the GCS sent it, so PRIMITIVE_STATUS echoes the
very degE7 commanded, not a round trip through the local frame.
"""

from __future__ import annotations

import math

from mussel_sim.geo import LocalFrame


class DegE7:
    """Local metres -> degE7 through the frame, remembering the last point (most sends repeat it)."""

    def __init__(self, frame: LocalFrame) -> None:
        self.frame = frame
        self._last: tuple[float, float, int, int] = (math.nan, math.nan, 0, 0)

    def remember(self, x_m: float, y_m: float, lat_e7: int, lon_e7: int) -> None:
        self._last = (x_m, y_m, lat_e7, lon_e7)

    def of(self, x_m: float, y_m: float) -> tuple[int, int]:
        cx, cy, lat_e7, lon_e7 = self._last
        if x_m != cx or y_m != cy:
            lat, lon = self.frame.to_geodetic(x_m, y_m)
            lat_e7, lon_e7 = round(float(lat) * 1e7), round(float(lon) * 1e7)
            self._last = (x_m, y_m, lat_e7, lon_e7)
        return lat_e7, lon_e7
