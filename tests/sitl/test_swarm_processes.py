"""One GCS, two `vil sitl` processes (one aPad each), real UDP, the wall clock: routing by system id,
and two aPads' scripts taking turns on one link (`missiontime.processes`)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from testkit import free_udp_port

from apad_sitl.vocabulary import Progress
from gcs.api import Location
from gcs.mission.scenario import load_scenario
from gcs.mission.swarm_run import run_swarm
from gcs.mission.world import LinkOptions, build_world
from missiontime import Clock, Scheduler, WallClock
from missiontime.processes import Processes
from mussel_sim.geo import LocalFrame, distance_m

pytestmark = pytest.mark.sitl
ROOT = Path(__file__).resolve().parents[2]



def test_one_gcs_drives_two_sitl_processes_over_udp(tmp_path: Path) -> None:
    scenario = load_scenario("pool12x2").with_overrides(duration_s=1.0)  # the swarm part only starts
    ports = [free_udp_port(), free_udp_port()]
    procs = [
        subprocess.Popen(
            [sys.executable, "-m", "apad_sitl", "--listen", f"udp:127.0.0.1:{port}", "--sysid", str(a.system_id),
             "--home", f"{a.home_lat_deg},{a.home_lon_deg}", "--duration", "60s", "--log-dir", str(tmp_path)],
            cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        for port, a in zip(ports, scenario.apads, strict=True)
    ]
    connect = ",".join(f"udp:127.0.0.1:{p}" for p in ports)
    world = build_world(scenario, WallClock(Scheduler()), tmp_path / "gcs", LinkOptions(connect=connect))
    try:
        for a in scenario.apads:
            assert world.api.wait_apad(timeout_s=15.0, apad_id=a.system_id) == a.system_id
        assert sorted(world.link.vehicles) == [1, 2]
        # Each aPad its own short Go To, both under way at once, each script waiting on its own clock.
        frame = LocalFrame(scenario.apads[0].home_lat_deg, scenario.apads[0].home_lon_deg)
        targets = {1: (3.0, 2.0), 2: (23.0, -2.0)}  # metres east, north of aPad 1's home
        finished: dict[int, Progress] = {}

        def script(sysid: int) -> object:
            def body(clock: Clock) -> None:
                api = world.api.on_clock(clock)
                lat, lon = (float(v) for v in frame.to_geodetic(*targets[sysid]))
                api.go_to(Location(lat, lon), apad_id=sysid)
                deadline = clock.time() + 40.0
                while api.goto_status(sysid) == Progress.IN_PROGRESS and clock.time() < deadline:
                    clock.sleep(0.2)
                finished[sysid] = api.goto_status(sysid)

            return body

        processes = Processes(world.clock)
        for sysid in (1, 2):
            processes.spawn(f"apad{sysid}", script(sysid))  # type: ignore[arg-type]
        processes.run()
        assert finished == {1: Progress.DONE, 2: Progress.DONE}
        for sysid, (x, y) in targets.items():
            here = world.api.position(sysid)
            lat, lon = frame.to_geodetic(x, y)
            assert float(distance_m(here.lat, here.lon, float(lat), float(lon))) < 1.5
        # And the swarm's start: both aPads share the fleet, each loop on its own aPad.
        outcome = run_swarm(world)
        assert sorted(outcome.loops) == [1, 2]
        assert outcome.shares.partition is not None
        assert sorted(m for ids in outcome.shares.partition.shares.values() for m in ids) == list(range(1, 13))
    finally:
        world.close()
        for p in procs:
            p.terminate()
            p.communicate(timeout=10)
    for p in procs:
        assert p.returncode == 0, p.stderr
    assert (tmp_path / "apad1.tlog").stat().st_size > 0 and (tmp_path / "apad2.tlog").stat().st_size > 0
