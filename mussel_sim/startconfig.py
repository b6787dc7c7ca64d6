"""Start configurations: which aMussels, where, with what battery; saved so runs repeat exactly.

On disk a start configuration is a GeoJSON FeatureCollection of Points (lon, lat) with
properties {"id": int, "battery": float in [0, 1]}, so GIS tools open it as it is. Floats are
written with Python's shortest round-trip repr: load(save(c)) == c bit for bit.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mussel_sim.geo import LocalFrame
from mussel_sim.placement import Area, place_uniform

# Paper, section V-A: starting batteries drawn from [0.6, 1].
START_BATTERY_RANGE = (0.6, 1.0)
MAX_MUSSEL_ID = 65535  # AMUSSEL_STATUS.mussel_id is uint16, 0 means "none"
MAX_CONFIG_ID = 2**32 - 1  # the model's id type; the comms runner refuses ids above MAX_MUSSEL_ID


@dataclass(frozen=True, eq=False)
class StartConfig:
    """ids `(n,)` uint32 (unique, >= 1; MAVLink needs <= 65535), lat_deg / lon_deg `(n,)` WGS84, battery_frac `(n,)`.

    Any integer ids are accepted (so out-of-range ones are refused, not wrapped) and stored as uint32.
    """

    ids: NDArray[np.integer[Any]]
    lat_deg: NDArray[np.float64]
    lon_deg: NDArray[np.float64]
    battery_frac: NDArray[np.float64]

    def __post_init__(self) -> None:
        ids = np.asarray(self.ids)
        n = ids.shape[0] if ids.ndim == 1 else -1
        arrays = (self.lat_deg, self.lon_deg, self.battery_frac)
        if n < 0 or any(np.shape(a) != (n,) for a in arrays):
            raise ValueError("start config: ids, lat_deg, lon_deg, battery_frac must all be (n,)")
        if n and (ids.min() < 1 or ids.max() > MAX_CONFIG_ID):
            raise ValueError(f"start config: ids must be in 1..{MAX_CONFIG_ID}")
        uniq, counts = np.unique(ids, return_counts=True)
        if (counts > 1).any():
            raise ValueError(f"start config: duplicate aMussel ids {uniq[counts > 1].tolist()}")
        battery = np.asarray(self.battery_frac, float)
        lat, lon = np.asarray(self.lat_deg, float), np.asarray(self.lon_deg, float)
        # Written as "not inside" so NaN is refused too.
        bad = ~((battery >= 0) & (battery <= 1))
        if bad.any():
            k = int(np.argmax(bad))
            raise ValueError(f"start config: batteries must be in [0, 1], aMussel {ids[k]} has {battery[k]}")
        bad = ~((np.abs(lat) <= 90) & (np.abs(lon) <= 180))
        if bad.any():
            k = int(np.argmax(bad))
            raise ValueError(f"start config: aMussel {ids[k]} at [{lon[k]}, {lat[k]}]: not WGS84 degrees [lon, lat]")
        object.__setattr__(self, "ids", ids.astype(np.uint32))
        object.__setattr__(self, "lat_deg", lat)
        object.__setattr__(self, "lon_deg", lon)
        object.__setattr__(self, "battery_frac", battery)

    @property
    def n(self) -> int:
        return int(self.ids.shape[0])

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, StartConfig):
            return NotImplemented
        return (
            np.array_equal(self.ids, other.ids)
            and np.array_equal(self.lat_deg, other.lat_deg)
            and np.array_equal(self.lon_deg, other.lon_deg)
            and np.array_equal(self.battery_frac, other.battery_frac)
        )

    __hash__ = None  # type: ignore[assignment]  # arrays inside: compare by value, never hash


def generate_start_config(
    area: Area,
    n: int,
    frame: LocalFrame,
    rng: np.random.Generator,
    first_id: int = 1,
    battery_range: tuple[float, float] = START_BATTERY_RANGE,
) -> StartConfig:
    """`n` aMussels with ids first_id.., uniform in `area`, batteries uniform in `battery_range`."""
    x_m, y_m = place_uniform(area, n, frame, rng)
    battery = rng.uniform(battery_range[0], battery_range[1], n)
    lat, lon = frame.to_geodetic(x_m, y_m)
    return StartConfig(np.arange(first_id, first_id + n), lat, lon, battery)


def start_config_from_positions(
    ids: ArrayLike, x_m: ArrayLike, y_m: ArrayLike, battery_frac: ArrayLike, frame: LocalFrame
) -> StartConfig:
    """A start configuration from any run's positions (local metres) and batteries."""
    lat, lon = frame.to_geodetic(x_m, y_m)
    return StartConfig(np.asarray(ids), lat, lon, np.asarray(battery_frac, float))


def start_config_to_geojson(config: StartConfig) -> dict[str, Any]:
    return {
        "type": "FeatureCollection",
        "features": [
            {
                "type": "Feature",
                "geometry": {"type": "Point", "coordinates": [float(lon), float(lat)]},
                "properties": {"id": int(i), "battery": float(b)},
            }
            for i, lat, lon, b in zip(
                config.ids, config.lat_deg, config.lon_deg, config.battery_frac, strict=True
            )
        ],
    }


def start_config_from_geojson(obj: dict[str, Any]) -> StartConfig:
    if obj.get("type") != "FeatureCollection":
        raise ValueError("start config: expected a GeoJSON FeatureCollection")
    ids, lats, lons, batteries = [], [], [], []
    for k, feat in enumerate(obj.get("features", [])):
        geom = feat.get("geometry") or {}
        props = feat.get("properties") or {}
        if geom.get("type") != "Point" or "id" not in props or "battery" not in props:
            raise ValueError(f"start config feature {k}: need a Point with properties id and battery")
        try:
            lon, lat = geom["coordinates"][:2]
            ids.append(int(props["id"]))
            lats.append(float(lat))
            lons.append(float(lon))
            batteries.append(float(props["battery"]))
        except (ValueError, TypeError, KeyError) as exc:
            raise ValueError(f"start config feature {k}: {exc}") from None
    return StartConfig(
        np.asarray(ids, dtype=np.int64), np.asarray(lats, float), np.asarray(lons, float), np.asarray(batteries, float)
    )


def save_start_config(path: str | Path, config: StartConfig) -> None:
    Path(path).write_text(json.dumps(start_config_to_geojson(config), indent=1) + "\n")


def load_start_config(path: str | Path) -> StartConfig:
    return start_config_from_geojson(json.loads(Path(path).read_text()))
