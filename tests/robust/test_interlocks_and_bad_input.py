"""Safety interlocks (geofence on both ends, acoustic range, no undocking on land) and bad input files."""

from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from robust_helpers import FRAME, SYSID, latlon_e7, sitl_pair

from apad_sitl.vocabulary import Latch
from gcs.link.apad_api import GeofenceError
from gcs.mission.headless import run_mission
from gcs.mission.world import headless_world
from gcs.scenario.reader import load_scenario
from mavlink_dialect import MAV_CMD_APAD_DOCK, MAV_CMD_APAD_UNDOCK, mavlink
from mussel_sim.fleet import step
from mussel_sim.fleet_state import FleetInputs
from mussel_sim.vocabulary import MusselState

pytestmark = pytest.mark.sitl

MISSIONS = Path(__file__).resolve().parents[2] / "missions"
SQUARE_M = [(-30.0, -30.0), (30.0, -30.0), (30.0, 30.0), (-30.0, 30.0)]


def fence_deg() -> list[tuple[float, float]]:
    lat, lon = FRAME.to_geodetic(np.array([p[0] for p in SQUARE_M]), np.array([p[1] for p in SQUARE_M]))
    return list(zip(lat.tolist(), lon.tolist(), strict=True))


def reposition(gcs, x_m: float, y_m: float) -> None:  # type: ignore[no-untyped-def]
    lat, lon = latlon_e7(x_m, y_m)
    gcs.send(mavlink.MAVLink_command_int_message(SYSID, 1, mavlink.MAV_FRAME_GLOBAL_INT,
                                                 mavlink.MAV_CMD_DO_REPOSITION, 0, 0, -1, 1, 0, float("nan"),
                                                 lat, lon, 0.0))


def test_sitl_refuses_go_to_outside_the_geofence_and_undocking_over_land() -> None:
    _clock, vehicle, gcs = sitl_pair(geofence_deg=fence_deg())
    gcs.heartbeat()
    reposition(gcs, 100.0, 0.0)
    assert gcs.acks(mavlink.MAV_CMD_DO_REPOSITION)[-1].result == mavlink.MAV_RESULT_DENIED
    assert "geofence" in [m for m in gcs.inbox if m.get_type() == "STATUSTEXT"][-1].text
    reposition(gcs, 20.0, 0.0)
    assert gcs.acks(mavlink.MAV_CMD_DO_REPOSITION)[-1].result == mavlink.MAV_RESULT_ACCEPTED

    gcs.mussel(24, 0.5, 0.0)
    vehicle.state = type(vehicle.state)(**{**vehicle.state.__dict__, "x_m": 0.0, "y_m": 0.0})
    gcs.command_long(MAV_CMD_APAD_DOCK, 1, 24)
    assert gcs.wait(lambda: vehicle.primitive.slot_state(1).latch == Latch.LATCHED, 15.0)
    # Pushed ashore (outside the water area) with the aMussel on board: it must not be released there.
    vehicle.state = type(vehicle.state)(**{**vehicle.state.__dict__, "x_m": 45.0, "y_m": 0.0})
    gcs.command_long(MAV_CMD_APAD_UNDOCK, 1, 24)
    assert gcs.acks(MAV_CMD_APAD_UNDOCK)[-1].result == mavlink.MAV_RESULT_DENIED
    assert vehicle.primitive.slot_state(1).latch == Latch.LATCHED
    vehicle.close()


def test_gcs_refuses_to_send_a_go_to_outside_the_geofence() -> None:
    world = headless_world(load_scenario("pool12"))
    try:
        world.api.wait_apad()
        sent = world.link.codec.stats.sent
        with pytest.raises(GeofenceError, match="outside geofence"):
            world.api.go_to((43.95, 15.45))  # a kilometre off, on land
        assert world.link.codec.stats.sent == sent  # never left the GCS
        home = next(iter(world.homes.values()))
        world.api.go_to(home)  # inside: fine
    finally:
        world.close()


@pytest.mark.parametrize("range_m", [100.0, 8.0])
def test_the_loop_calls_up_only_with_the_apad_within_acoustic_range(tmp_path: Path, range_m: float) -> None:
    base = load_scenario("bay24").with_overrides(strategy="greedy", duration_s=900.0)
    s = replace(base, fleet=replace(base.fleet, acoustic_range_m=range_m))
    run_mission(s, tmp_path)
    events = [json.loads(x) for x in (tmp_path / "events.jsonl").read_text().splitlines()]
    calls = [e for e in events if e["event"] == "call_up"]
    assert calls and all(e["distance_m"] <= range_m for e in calls)
    assert "STATUSTEXT" not in (tmp_path / "events.jsonl").read_text()  # the fleet never had to refuse one


def test_the_fleet_itself_refuses_to_surface_out_of_range() -> None:
    world = headless_world(load_scenario("bay24"))
    try:
        fleet = world.fleet
        first = int(fleet.state.ids[0])
        far = FleetInputs.make(apads={1: (1e4, 0.0)}, surface=[first])
        new, events = step(fleet.state, far, fleet.params, fleet.rng, 1.0)
        assert events.surface_refused_out_of_range_ids.tolist() == [first]
        assert new.state[0] == MusselState.ACTIVE
    finally:
        world.close()


def vil_run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "gcs.cli", "run", *args], capture_output=True, text=True, timeout=60)


def scenario_with(tmp_path: Path, area: str | None = None, start: str | None = None) -> Path:
    text = (MISSIONS / "pool12.toml").read_text()
    text = text.replace('area = "areas/pool.geojson"', f'area = "{area or MISSIONS / "areas/pool.geojson"}"')
    text = text.replace('start_config = "starts/pool12.geojson"',
                        f'start_config = "{start or MISSIONS / "starts/pool12.geojson"}"')
    path = tmp_path / "s.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("area_text, expect", [
    ("{not json", "not JSON"),
    ('{"type": "Point", "coordinates": [15.4, 43.9]}', "no Polygon"),
    ('{"type": "Polygon", "coordinates": [[[0, 0], [1, 1], [1, 0], [0, 1], [0, 0]]]}', "not valid"),
    ('{"type": "Polygon", "coordinates": [[[4394000, 1544000], [4394100, 1544000], [4394100, 1544100], '
     '[4394000, 1544000]]]}', "WGS84"),
    ('{"type": "Polygon"}', "bad area"),
])
def test_a_bad_area_file_is_one_line_and_exit_2(tmp_path: Path, area_text: str, expect: str) -> None:
    (tmp_path / "a.geojson").write_text(area_text)
    done = vil_run(str(scenario_with(tmp_path, area=str(tmp_path / "a.geojson"))), "--duration", "60s")
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert done.stderr.count("\n") == 1 and expect in done.stderr, done.stderr


def test_bad_start_configs_are_one_line_and_exit_2(tmp_path: Path) -> None:
    good = json.loads((MISSIONS / "starts/pool12.geojson").read_text())
    dup = json.loads(json.dumps(good))
    dup["features"][1]["properties"]["id"] = dup["features"][0]["properties"]["id"]
    cases = {"missing.geojson": None, "garbage.geojson": "[1, 2", "dup.geojson": json.dumps(dup),
             "short.geojson": json.dumps({**good, "features": good["features"][:3]})}
    said = {}
    for name, text in cases.items():
        if text is not None:
            (tmp_path / name).write_text(text)
        done = vil_run(str(scenario_with(tmp_path, start=str(tmp_path / name))), "--duration", "60s")
        assert done.returncode == 2 and "Traceback" not in done.stderr, (name, done.stderr)
        assert done.stderr.count("\n") == 1, (name, done.stderr)
        said[name] = done.stderr
    assert "duplicate aMussel ids" in said["dup.geojson"]  # the run above says why (no second run to ask)


def test_bad_fault_flags_are_refused_by_the_parser() -> None:
    for flags in (["--loss", "1.5"], ["--latency", "-1"], ["--outage", "30"], ["--duplicate", "x"]):
        done = vil_run("pool12", *flags)
        assert done.returncode == 2 and "Traceback" not in done.stderr
