"""Experimental areas (GeoJSON polygons) and uniform random placement inside them.

Sampling happens in the scenario's `LocalFrame` metric plane, so "uniform" means uniform per
square metre (uniform in degrees would not be, away from the equator).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from numpy.typing import NDArray
from shapely.geometry import MultiPolygon, Polygon, shape
from shapely.geometry.base import BaseGeometry

from mussel_sim.geo import LocalFrame


@dataclass(frozen=True)
class Area:
    """A polygon (or multipolygon) of the experimental area, in WGS84 lon/lat (GeoJSON order)."""

    geometry: BaseGeometry
    name: str = ""

    def __post_init__(self) -> None:
        if not isinstance(self.geometry, Polygon | MultiPolygon) or self.geometry.is_empty:
            raise ValueError(f"area {self.name!r} must be a non-empty Polygon or MultiPolygon")
        for lon, lat in shapely.get_coordinates(self.geometry):
            if not (np.isfinite(lon) and np.isfinite(lat)):
                raise ValueError(f"area {self.name!r}: vertex [{lon}, {lat}] is not a finite [lon, lat]")
            if not (-90 <= lat <= 90 and -180 <= lon <= 180):
                raise ValueError(f"area {self.name!r}: vertex [{lon}, {lat}] is not WGS84 degrees [lon, lat] "
                                 "(GeoJSON order)")
        if not self.geometry.is_valid:
            raise ValueError(f"area {self.name!r}: the polygon is not valid (self-intersecting or degenerate)")

    @property
    def centroid_lat_lon_deg(self) -> tuple[float, float]:
        """A representative point inside the area, a natural origin for the scenario's frame."""
        p = self.geometry.representative_point()
        return float(p.y), float(p.x)

    def frame(self) -> LocalFrame:
        lat, lon = self.centroid_lat_lon_deg
        return LocalFrame(lat, lon)

    def to_local(self, frame: LocalFrame) -> BaseGeometry:
        """The same area in the frame's metres (vertices projected; edges stay straight there)."""

        def project(coords: NDArray[np.float64]) -> NDArray[np.float64]:
            x, y = frame.to_local(coords[:, 1], coords[:, 0])
            return np.column_stack([x, y])

        return shapely.transform(self.geometry, project)


def area_from_geojson(obj: dict[str, Any], name: str = "") -> Area:
    """The union of every polygon in a GeoJSON geometry, Feature or FeatureCollection."""
    kind = obj.get("type")
    with np.errstate(invalid="ignore"):  # a NaN vertex: refused by `Area` in words, not warned about
        if kind == "FeatureCollection":
            geoms = [shape(f["geometry"]) for f in obj.get("features", []) if f.get("geometry")]
        elif kind == "Feature":
            geoms = [shape(obj["geometry"])]
        else:
            geoms = [shape(obj)]
    polys = [g for g in geoms if isinstance(g, Polygon | MultiPolygon)]
    if not polys:
        raise ValueError(f"area {name!r}: no Polygon or MultiPolygon in the GeoJSON")
    geom = polys[0] if len(polys) == 1 else shapely.union_all(polys)
    return Area(geom, name)


def load_area(path: str | Path) -> Area:
    path = Path(path)
    return area_from_geojson(json.loads(path.read_text()), name=path.stem)


def place_uniform(
    area: Area, n: int, frame: LocalFrame, rng: np.random.Generator
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """`n` points uniform inside `area`: (x_m `(n,)`, y_m `(n,)`) in `frame`.

    Vectorised rejection sampling from the bounding box; each round draws enough candidates for
    the expected acceptance rate, so thin or holed areas still take a few rounds at most.
    """
    local = area.to_local(frame)
    shapely.prepare(local)
    xmin, ymin, xmax, ymax = local.bounds
    accept_rate = max(local.area / max((xmax - xmin) * (ymax - ymin), 1e-12), 1e-3)
    xs: list[NDArray[np.float64]] = []
    ys: list[NDArray[np.float64]] = []
    have = 0
    while have < n:
        m = int((n - have) / accept_rate * 1.2) + 16
        x = rng.uniform(xmin, xmax, m)
        y = rng.uniform(ymin, ymax, m)
        inside = shapely.contains_xy(local, x, y)
        xs.append(x[inside])
        ys.append(y[inside])
        have += int(inside.sum())
    return np.concatenate(xs)[:n], np.concatenate(ys)[:n]
