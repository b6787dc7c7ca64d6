"""run.geojson: a run for GIS tools (RFC 7946: WGS 84, [lon, lat], exterior rings counterclockwise).

Features: the area (Polygon or MultiPolygon); each aPad's track, a LineString whose `times`
property holds one ISO 8601 UTC timestamp per position (the log's clock; lockstep runs use a
fixed nominal date) and `mission_times_s` the same instants in mission seconds; one Point per
aMussel at its deployment position with its figures (uptime, dockings, depletion, time per state).
"""

from __future__ import annotations

import json
import math
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from shapely.geometry import MultiPolygon, Polygon, mapping
from shapely.geometry.polygon import orient

from gcs.report.run_data import RunData

DECIMALS = 7  # about 1 cm


def write_geojson(data: RunData, path: Path) -> Path:
    features = [f for f in (_area(data), *(_track(data, k) for k in range(len(data.tracks)))) if f is not None]
    features += [_mussel(data, k) for k in range(len(data.mussels))]
    collection = {"type": "FeatureCollection", "name": data.title, "features": features}
    path.write_text(json.dumps(collection, indent=1, allow_nan=False) + "\n")
    return path


def timestamp(data: RunData, t_s: float) -> str:
    """The instant `t_s` of mission time on the log's clock, ISO 8601 UTC."""
    when = datetime.fromtimestamp(data.start_us / 1e6 + t_s, UTC)
    return when.isoformat(timespec="milliseconds").replace("+00:00", "Z")


def _position(lon: float, lat: float) -> list[float]:
    return [round(float(lon), DECIMALS), round(float(lat), DECIMALS)]


def _area(data: RunData) -> dict[str, Any] | None:
    geometry = data.area
    if geometry is None and data.outline_lat_deg.size:  # no scenario: the outline the console drew
        rings = np.split(np.column_stack([data.outline_lon_deg, data.outline_lat_deg]),
                         np.flatnonzero(np.isnan(data.outline_lat_deg)))
        geometry = MultiPolygon([Polygon(r[np.isfinite(r).all(axis=1)]) for r in rings])
    if geometry is None:
        return None
    geometry = shapely.transform(geometry, lambda xy: np.round(xy, DECIMALS))
    parts = [orient(p, sign=1.0) for p in getattr(geometry, "geoms", [geometry])]  # RFC 7946 §3.1.6
    shape = parts[0] if len(parts) == 1 else MultiPolygon(parts)
    return {"type": "Feature", "properties": {"kind": "area"}, "geometry": mapping(shape)}


def _track(data: RunData, k: int) -> dict[str, Any] | None:
    track = data.tracks[k]
    if track.t_s.size < 2:  # a LineString needs two positions
        return None
    coords = [_position(lo, la) for lo, la in zip(track.lon_deg, track.lat_deg, strict=True)]
    return {
        "type": "Feature",
        "properties": {
            "kind": "apad_track", "apad": track.system_id, "cost_m": round(float(track.cost_m[-1]), 3),
            "times": [timestamp(data, float(t)) for t in track.t_s],
            "mission_times_s": [round(float(t), 3) for t in track.t_s],
        },
        "geometry": {"type": "LineString", "coordinates": coords},
    }


def _number(x: float, digits: int = 3) -> float | None:
    return round(x, digits) if math.isfinite(x) else None


def _mussel(data: RunData, k: int) -> dict[str, Any]:
    m = data.mussels[k]
    deployed = math.isfinite(m.start_lat_deg) and math.isfinite(m.start_lon_deg)
    end = math.isfinite(m.end_lat_deg) and math.isfinite(m.end_lon_deg)
    return {
        "type": "Feature",
        "properties": {
            "kind": "amussel", "amussel_id": m.id, "apad": m.apad or None,
            "uptime_pct": _number(m.uptime_pct), "dockings": m.dockings, "never_collected": m.never_collected,
            "depleted_s": _number(m.depleted_s, 1), "first_depleted_s": m.first_depleted_s,
            "start_battery": _number(m.start_battery, 4),
            "end_battery": _number(m.end_battery, 4), "end_state": m.end_state,
            "state_s": {state: _number(s, 1) for state, s in m.state_s.items()},
            "end_position": _position(m.end_lon_deg, m.end_lat_deg) if end else None,
        },
        # RFC 7946 §3.2: a Feature with no known position has a null geometry.
        "geometry": {"type": "Point", "coordinates": _position(m.start_lon_deg, m.start_lat_deg)} if deployed else None,
    }
