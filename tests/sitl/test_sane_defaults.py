"""Sane defaults (issue 14) as a user meets them: `vil sitl --scenario` serves the scenario's aPads
where the scenario puts them, bad durations and unknown scenarios are one line and exit 2, and a
fleet of 40 drawn from the seed runs."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from testkit import free_udp_port, scenario_variant

from gcs.cli.main import build_parser, main
from gcs.cli.sitl import scenario_apads
from gcs.link.apad_api import Location
from gcs.link.command_protocol import CommandError
from gcs.mission.world import LinkOptions, build_world
from gcs.scenario.reader import MISSIONS_DIR, load_scenario
from missiontime import Scheduler, WallClock
from mussel_sim.geo import distance_m

pytestmark = pytest.mark.sitl
ROOT = Path(__file__).resolve().parents[2]
SHIPPED = ("bay-capacity, bay120, bay120-acoustic, bay120-sleep, bay24, bay24-acoustic, pool12, pool12-acoustic, "
           "pool12x2, stress240")


def refusal(capsys: pytest.CaptureFixture[str], *argv: str) -> str:
    """`vil ARGV` refused: exit 2 and the one error line (argparse's usage lines come above it)."""
    try:
        code = main(list(argv))
    except SystemExit as exc:
        code = int(exc.code or 0)
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err, err
    return err.strip().splitlines()[-1]


@pytest.mark.parametrize("argv, line", [
    (["run", "pool12", "--duration", "40"], "vil run: error: argument --duration: 40 has no unit: say 40s, 40min"),
    (["sitl", "--duration", "40"], "vil sitl: error: argument --duration: 40 has no unit: say 40s, 40min or 40h"),
    (["run", "pool12", "--latency", "0.2"], "argument --latency: 0.2 has no unit: say 0.2s"),
    (["run", "pool12", "--outage", "92:112"], "argument --outage: START:END 92:112: 92 has no unit"),
    (["replay", "runs/latest", "--start", "90"], "argument --start: 90 has no unit"),
])
def test_a_duration_without_a_unit_is_refused_by_every_command(capsys: pytest.CaptureFixture[str], argv: list[str],
                                                                line: str) -> None:
    assert line in refusal(capsys, *argv)


@pytest.mark.parametrize("argv", [["run", "pool13"], ["sitl", "--scenario", "pool13"],
                                  ["gcs", "--sitl", "--scenario", "pool13"], ["replay", "RUN", "--scenario", "pool13"]])
def test_a_scenario_found_nowhere_is_one_line_naming_the_shipped_ones(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                                     capsys: pytest.CaptureFixture[str],
                                                                     argv: list[str]) -> None:
    monkeypatch.chdir(tmp_path)
    run = tmp_path / "run"
    run.mkdir()
    (run / "events.jsonl").write_text("")
    (run / "gcs.tlog").write_bytes(b"")
    code = main([str(run) if a == "RUN" else a for a in argv])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1, err
    assert err == (f"vil {argv[0]}: pool13: no such scenario file, here or in {MISSIONS_DIR}; did you mean pool12? "
                   f"(shipped: {SHIPPED})\n")
    assert not (tmp_path / "runs").exists()


def test_sitl_with_a_scenario_of_one_apad_refuses_a_second_and_a_home_of_its_own(capsys: pytest.CaptureFixture[str]
                                                                                ) -> None:
    assert refusal(capsys, "sitl", "--scenario", "pool12", "--count", "2") == \
        "vil sitl: --count 2: pool12 has 1 aPad (one [apad] table)"
    assert refusal(capsys, "sitl", "--scenario", "pool12", "--home", "45,13").startswith(
        "vil sitl: --home and --scenario both say it")


def test_vil_sitl_scenario_pool12_serves_its_apad_at_its_home_with_its_geofence(tmp_path: Path) -> None:
    scenario = load_scenario("pool12").with_overrides(duration_s=1.0)
    a = scenario.apad
    port = free_udp_port()
    proc = subprocess.Popen(
        [sys.executable, "-m", "gcs.cli", "sitl", "--scenario", "pool12", "--listen", f"udp:127.0.0.1:{port}",
         "--duration", "60s", "--log-dir", str(tmp_path)],
        cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    # No geofence on the GCS side: the Go To below goes out, so the refusal is the aPad's own.
    world = build_world(scenario, WallClock(Scheduler()), tmp_path / "gcs",
                        LinkOptions(connect=f"udp:127.0.0.1:{port}", geofence_buffer_m=None))
    try:
        assert world.api.wait_apad(timeout_s=15.0) == a.system_id
        here = world.api.position(a.system_id)
        assert float(distance_m(here.lat, here.lon, a.home_lat_deg, a.home_lon_deg)) < 0.05
        with pytest.raises(CommandError, match="DENIED"):
            world.api.go_to(Location(a.home_lat_deg, a.home_lon_deg - 0.001))  # 80 m west, ashore
    finally:
        world.close()
        proc.terminate()
        out, err = proc.communicate(timeout=10)
    assert proc.returncode == 0, err
    assert out.splitlines() == [
        f"vil sitl: pool12 ({MISSIONS_DIR / 'pool12.toml'}): its aPad at its home with the scenario's parameters, "
        "its water area as the geofence",
        f"vil sitl: aPad sysid 1 listening on udp:127.0.0.1:{port}, home 43.940000,15.439838 (pool12's), "
        f"current 0,0 m/s, logs in {tmp_path}",
    ]


def test_each_apad_of_a_swarm_scenario_comes_from_its_own_table() -> None:
    scenario = load_scenario("pool12x2")
    args = build_parser(["sitl"]).parse_args(["sitl", "--scenario", "pool12x2", "--param", "SPEED_MAX=0.3"])
    apads, fence = scenario_apads(scenario, args)
    assert [(p.system_id, p.home_lat_deg, p.home_lon_deg) for p in apads] == [
        (a.system_id, a.home_lat_deg, a.home_lon_deg) for a in scenario.apads]
    assert [p.params.sysid_thismav for p in apads] == [1, 2] and {p.params.speed_max_mps for p in apads} == {0.3}
    assert len(fence) > 3  # the pool grown by the world's margin, as `vil run` gives the embedded aPads
    args = build_parser(["sitl"]).parse_args(["sitl", "--scenario", "pool12x2", "--count", "1"])
    assert [p.system_id for p in scenario_apads(scenario, args)[0]] == [1]


def test_vil_sitl_without_home_or_scenario_starts_at_pool12s_home_and_says_so() -> None:
    from apad_sitl.serve import DEFAULT_HOME, DEFAULT_HOME_NOTE

    pool = load_scenario("pool12").apad
    assert (pool.home_lat_deg, pool.home_lon_deg) == DEFAULT_HOME  # `vil gcs`'s default: no transit at start
    assert "pool12's" in DEFAULT_HOME_NOTE and "--home" in DEFAULT_HOME_NOTE


def test_forty_amussels_drawn_from_the_seed_run_where_the_saved_twelve_would_not(tmp_path: Path,
                                                                                  capsys: pytest.CaptureFixture[str]
                                                                                  ) -> None:
    forty = scenario_variant("pool12", tmp_path / "pool40.toml", {"count = 12": "count = 40",
                                                                   'name = "pool12"': 'name = "pool40"'})
    without = refusal(capsys, "run", str(forty), "--out", str(tmp_path / "runs"))
    assert "holds 12 aMussels, the scenario says 40 (to draw 40 from the seed: vil run --draw-fleet" in without
    out = tmp_path / "r.json"
    assert main(["run", str(forty), "--draw-fleet", "--seed", "4", "--duration", "3min", "--out",
                 str(tmp_path / "runs"), "--json", str(out), "--jobs", "1"]) == 0
    result = json.loads(out.read_text())
    assert len(result["mussels"]) == 40 and result["seed"] == 4 and result["duration_s"] == 180.0
    assert "saved start configuration" not in capsys.readouterr().err  # the fleet is drawn: no notice
