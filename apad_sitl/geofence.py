"""The aPad's geofence: the water area, in its local metres. Go To targets outside it and undocking
outside it are refused (an aMussel released on land is lost)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from mussel_sim.geo import LocalFrame

KNOWN_FIXES = 4096  # the fixes a geofence remembers the answer for


@dataclass(frozen=True)
class Geofence:
    """The water area in the aPad's local metres; a point on the boundary is inside."""

    polygon: Any  # shapely Polygon, prepared
    frame: LocalFrame  # the metres the polygon is in
    # (lat, lon) -> inside: a planner asks about the same fixes again and again (a sleeper's last one)
    _known: dict[tuple[float, float], bool] = field(default_factory=dict, compare=False, repr=False)

    @staticmethod
    def of(ring_deg: Sequence[tuple[float, float]], frame: LocalFrame) -> Geofence:
        """From a (lat, lon) ring; ValueError if it is no simple polygon with an area."""
        import shapely

        if len(ring_deg) < 3:
            raise ValueError("a geofence needs at least 3 (lat, lon) vertices")
        lat = [p[0] for p in ring_deg]
        lon = [p[1] for p in ring_deg]
        x, y = frame.to_local(lat, lon)
        polygon = shapely.Polygon(list(zip(map(float, x), map(float, y), strict=True)))
        if not polygon.is_valid or polygon.area <= 0:
            raise ValueError("the geofence polygon is not a simple ring with an area")
        shapely.prepare(polygon)
        return Geofence(polygon, frame)

    def contains(self, x_m: float, y_m: float) -> bool:
        import shapely

        return bool(shapely.intersects_xy(self.polygon, x_m, y_m))

    @property
    def remembered(self) -> int:
        """How many fixes' answers it keeps now (at most KNOWN_FIXES)."""
        return len(self._known)

    def contains_deg(self, lat_deg: float, lon_deg: float) -> bool:
        known = self._known.get((lat_deg, lon_deg))
        if known is None:
            if len(self._known) >= KNOWN_FIXES:
                self._known.clear()  # bounded: a long mission's drifting fixes start it again
            x, y = self.frame.to_local(lat_deg, lon_deg)
            known = self._known[(lat_deg, lon_deg)] = self.contains(float(x), float(y))
        return known
