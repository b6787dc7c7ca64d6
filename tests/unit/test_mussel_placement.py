"""Areas, uniform placement and start configurations."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import shapely
from shapely.geometry import box

from mussel_sim.fleet import step
from mussel_sim.fleet_state import FleetInputs, FleetParams, initial_state, start_config_of
from mussel_sim.geo import LocalFrame, distance_m, planar_distance_m
from mussel_sim.placement import area_from_geojson, load_area, place_uniform
from mussel_sim.startconfig import (
    StartConfig,
    generate_start_config,
    load_start_config,
    save_start_config,
    start_config_from_positions,
)

AREA_PATH = Path(__file__).resolve().parents[1] / "data" / "mussel_l_area.geojson"


def test_polygon_placement_keeps_every_point_inside() -> None:
    area = load_area(AREA_PATH)
    frame = area.frame()
    x, y = place_uniform(area, 5000, frame, np.random.default_rng(3))
    assert x.shape == y.shape == (5000,)
    lat, lon = frame.to_geodetic(x, y)
    assert shapely.contains_xy(area.geometry, lon, lat).all()  # in WGS84, the file's own polygon
    hole = shapely.Polygon(area.geometry.interiors[0])
    assert not shapely.contains_xy(hole, lon, lat).any()


def test_placement_is_uniform_per_square_metre() -> None:
    # A 100 m x 100 m square split in quarters: each quarter gets 1/4 of the points.
    sq = {"type": "Polygon", "coordinates": [[[15.44, 43.93], [15.4412, 43.93], [15.4412, 43.9309], [15.44, 43.9309]]]}
    area = area_from_geojson(sq)
    frame = LocalFrame(43.93, 15.44)
    local = area.to_local(frame)
    x, y = place_uniform(area, 40_000, frame, np.random.default_rng(5))
    xmin, ymin, xmax, ymax = local.bounds
    q = box(xmin, ymin, (xmin + xmax) / 2, (ymin + ymax) / 2)
    expected = q.intersection(local).area / local.area
    frac = shapely.contains_xy(q, x, y).mean()
    sigma = np.sqrt(expected * (1 - expected) / 40_000)
    assert abs(frac - expected) < 4 * sigma


def test_area_rejects_geojson_without_a_polygon() -> None:
    with pytest.raises(ValueError, match="Polygon"):
        area_from_geojson({"type": "Point", "coordinates": [15.44, 43.93]})


def test_generated_start_config_follows_the_paper() -> None:
    area = load_area(AREA_PATH)
    cfg = generate_start_config(area, 24, area.frame(), np.random.default_rng(11))
    np.testing.assert_array_equal(cfg.ids, np.arange(1, 25))
    assert ((cfg.battery_frac >= 0.6) & (cfg.battery_frac <= 1.0)).all()
    assert shapely.contains_xy(area.geometry, cfg.lon_deg, cfg.lat_deg).all()


def test_same_seed_same_fleet() -> None:
    area = load_area(AREA_PATH)
    a = generate_start_config(area, 50, area.frame(), np.random.default_rng(2))
    b = generate_start_config(area, 50, area.frame(), np.random.default_rng(2))
    c = generate_start_config(area, 50, area.frame(), np.random.default_rng(3))
    assert a == b
    assert a != c


def test_start_config_round_trips_bit_for_bit(tmp_path: Path) -> None:
    area = load_area(AREA_PATH)
    cfg = generate_start_config(area, 30, area.frame(), np.random.default_rng(7), first_id=100)
    path = tmp_path / "start.geojson"
    save_start_config(path, cfg)
    back = load_start_config(path)
    assert back == cfg
    for a, b in ((back.lat_deg, cfg.lat_deg), (back.battery_frac, cfg.battery_frac)):
        assert a.tobytes() == b.tobytes()
    # What a GIS tool sees: points at (lon, lat) with id and battery properties.
    doc = json.loads(path.read_text())
    feat = doc["features"][0]
    assert doc["type"] == "FeatureCollection"
    assert feat["geometry"] == {"type": "Point", "coordinates": [cfg.lon_deg[0], cfg.lat_deg[0]]}
    assert feat["properties"] == {"id": 100, "battery": cfg.battery_frac[0]}


def test_start_config_saved_from_a_run_reloads_to_the_same_state(tmp_path: Path) -> None:
    frame = LocalFrame(43.9375, 15.4405)
    x = np.array([0.0, 12.5, -30.25])
    y = np.array([4.0, -8.0, 22.0])
    cfg = start_config_from_positions([9, 3, 5], x, y, [0.7, 0.8, 0.9], frame)
    save_start_config(tmp_path / "run.geojson", cfg)
    state = initial_state(load_start_config(tmp_path / "run.geojson"), frame, FleetParams())
    np.testing.assert_array_equal(state.ids, [3, 5, 9])  # sorted by id
    np.testing.assert_allclose(state.x_m, [12.5, -30.25, 0.0], atol=1e-6)
    np.testing.assert_allclose(state.y_m, [-8.0, 22.0, 4.0], atol=1e-6)
    np.testing.assert_array_equal(state.battery_frac, [0.8, 0.9, 0.7])


@pytest.mark.parametrize(
    "ids, battery, match",
    [([1, 1], [0.7, 0.7], "duplicate"), ([0, 1], [0.7, 0.7], "ids must be"), ([1, 2], [0.7, 1.2], "batteries")],
)
def test_bad_start_configs_are_refused(ids: list[int], battery: list[float], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        StartConfig(np.array(ids), np.zeros(2), np.zeros(2), np.array(battery))


def test_planar_ranges_agree_with_the_geodesic() -> None:
    # The acoustic-range check works in the local plane; 3 km from the origin it is still exact
    # to a millimetre over 100 m, against pyproj's WGS84 geodesic.
    frame = LocalFrame(43.9375, 15.4405)
    x1 = np.array([3000.0, -2000.0, 0.0])
    y1 = np.array([0.0, 2500.0, -3000.0])
    x2, y2 = x1 + 60.0, y1 + 80.0
    lat1, lon1 = frame.to_geodetic(x1, y1)
    lat2, lon2 = frame.to_geodetic(x2, y2)
    np.testing.assert_allclose(planar_distance_m(x1, y1, x2, y2), 100.0)
    np.testing.assert_allclose(distance_m(lat1, lon1, lat2, lon2), 100.0, atol=1e-3)


def test_any_step_of_a_run_saves_as_a_start_config(tmp_path: Path) -> None:
    area = load_area(AREA_PATH)
    frame = area.frame()
    params = FleetParams()
    s = initial_state(generate_start_config(area, 12, frame, np.random.default_rng(1)), frame, params)
    rng = np.random.default_rng(2)
    for _ in range(30):
        s, _ = step(s, FleetInputs(), params, rng, 1.0)
    save_start_config(tmp_path / "t30.geojson", start_config_of(s, frame))
    again = initial_state(load_start_config(tmp_path / "t30.geojson"), frame, params)
    np.testing.assert_array_equal(again.ids, s.ids)
    np.testing.assert_array_equal(again.battery_frac, s.battery_frac)
    np.testing.assert_allclose(again.x_m, s.x_m, atol=1e-6)
    np.testing.assert_allclose(again.y_m, s.y_m, atol=1e-6)
