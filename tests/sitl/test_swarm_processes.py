"""One GCS, two `vil sitl` processes (one aPad each), real UDP, the wall clock: routing by system id,
and two aPads' scripts taking turns on one link (`missiontime.processes`); and a lockstep swarm
whose planning walks the C stack (issue 19)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from testkit import free_udp_port

from apad_sitl.vocabulary import Progress
from gcs.link.apad_api import Location
from gcs.loop.control import EndReason
from gcs.mission.headless import run_mission
from gcs.mission.session import MissionSession
from gcs.mission.world import LinkOptions, build_world
from gcs.scenario.reader import load_scenario
from gcs.strategies import STRATEGIES, CostWeights, Plan, PlanInput
from missiontime import Clock, Scheduler, WallClock
from missiontime.processes import Processes
from mussel_sim.geo import LocalFrame, distance_m

pytestmark = pytest.mark.sitl
ROOT = Path(__file__).resolve().parents[2]
# Brisk aPads (test_listing1.py's): the Go Tos are the same, at 2 m/s instead of 0.5 (seconds of wall time idle).
BRISK = ["--param", "SPEED_MAX=2.0", "--param", "ACCEL_MAX=1.0"]


def test_one_gcs_drives_two_sitl_processes_over_udp(tmp_path: Path) -> None:
    scenario = load_scenario("pool12x2").with_overrides(duration_s=1.0)  # the swarm part only starts
    ports = [free_udp_port(), free_udp_port()]
    procs = [
        subprocess.Popen(
            [sys.executable, "-m", "apad_sitl", "--listen", f"udp:127.0.0.1:{port}", "--sysid", str(a.system_id),
             "--home", f"{a.home_lat_deg},{a.home_lon_deg}", "--duration", "60s", "--log-dir", str(tmp_path),
             *BRISK],
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
        session = MissionSession(world)
        assert session.start()
        session.run()
        outcome = session.outcome()
        assert sorted(outcome.loops) == [1, 2]
        assert outcome.shares is not None and outcome.shares.partition is not None
        assert sorted(m for ids in outcome.shares.partition.shares.values() for m in ids) == list(range(1, 13))
    finally:
        world.close()
        for p in procs:
            p.terminate()
            p.communicate(timeout=10)
    for p in procs:
        assert p.returncode == 0, p.stderr
    assert (tmp_path / "apad1.tlog").stat().st_size > 0 and (tmp_path / "apad2.tlog").stat().st_size > 0


def test_a_swarm_whose_strategy_builds_large_numpy_temporaries_completes(monkeypatch: pytest.MonkeyPatch) -> None:
    """Issue 19: numpy elides a temporary of over 256 KiB (`(a + b) * c` reuses the buffer of
    `a + b`) only after walking the C stack with glibc's `backtrace()` to see who called it. On a
    greenlet's switched stack that walk ran off the stack: this very run (five aPads, rolling)
    died of a segmentation fault at its second plan. On a thread of its own each script has a real
    C stack: the swarm plans with such temporaries to the mission's end."""
    scenario = load_scenario("bay120").with_overrides(duration_s=1200.0, strategy="rolling")
    name = scenario.mission.collect_strategy
    plain = STRATEGIES[name]
    big = np.linspace(0.0, 1.0, 1 << 19)  # 4 MiB, sixteen times numpy's elision threshold
    planned: list[float] = []

    def heavy(inp: PlanInput, weights: CostWeights) -> Plan:
        total = (big + big) * 0.5 + big  # two temporaries elided: `big + big`, then `... * 0.5`
        planned.append(float(total[-1]))
        return plain(inp, weights)

    monkeypatch.setitem(STRATEGIES, name, heavy)
    r = run_mission(scenario)
    assert len(planned) > 100 and set(planned) == {2.0}  # planned all along, with the temporaries ...
    assert sorted(a["sysid"] for a in r.apads) == [1, 2, 3, 4, 5] and r.cycles > 0
    assert {a["end_reason"] for a in r.apads} == {EndReason.MISSION_TIME}  # ... by every aPad's loop, to the end
    assert r.misplaced == []
