"""Bad input for every `vil` command, each class of issue 10 a case: the real process exits 2 with
one error naming the flag or the file and field, no traceback, and nothing starts (no console, no run).

A hang fails through the subprocess timeout; a console that opened without a terminal would hang.
"""

from __future__ import annotations

import json
import math
import socket
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from gcs.mission.headless import run_mission
from gcs.scenario.reader import load_scenario

MISSIONS = Path(__file__).resolve().parents[2] / "missions"


def vil(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "gcs.cli", *args], capture_output=True, text=True, timeout=60,
                          cwd=cwd, stdin=subprocess.DEVNULL)


def refused(done: subprocess.CompletedProcess[str], *expect: str) -> str:
    """The one error line (no usage block above it); asserts exit 2 and no traceback."""
    assert done.returncode == 2 and "Traceback" not in done.stderr, done.stderr
    assert done.stderr.count("\n") == 1, done.stderr
    last = done.stderr.strip().splitlines()[-1]
    assert all(e in last for e in expect), done.stderr
    return last


@pytest.fixture(scope="module")
def run_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("run") / "pool12-cautious-seed1-run1"
    run_mission(load_scenario("pool12").with_overrides(duration_s=60.0), folder)
    return folder


@pytest.fixture()
def busy_udp_port() -> Iterator[int]:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        sock.bind(("127.0.0.1", 0))
        yield sock.getsockname()[1]


# --- numbers in flags: non-finite, negative, huge ----------------------------------------------

@pytest.mark.parametrize("command, flag, value, expect", [
    ("run", "--seed", "-1", "-1 is outside [0, "),
    ("run", "--seeds", "1000000000", "is outside [1, 1000]"),
    ("run", "--jobs", "0", "0 is outside [1, 256]"),
    ("run", "--latency", "inf", "'inf' is not a duration"),
    ("run", "--jitter", "nan", "'nan' is not a duration"),
    ("run", "--latency", "1000h", "is more than 5 s"),
    ("run", "--loss", "nan", "nan is not a finite number"),
    ("run", "--theta", "inf", "inf is not a finite number"),
    ("run", "--theta", "1e9", "is outside [0.001, 10000.0]"),
    ("run", "--duration", "1000000000h", "more than 90 days"),
    ("run", "--outage", "0s:inf", "START:END"),
    ("gcs", "--speed", "nan", "nan is not a finite number"),
    ("gcs", "--speed", "-1", "is outside [0.1, 1000.0]"),
    ("sitl", "--duration", "inf", "'inf' is not a duration"),
    ("sitl", "--duration", "1e300", "'1e300' is not a duration"),
    ("sitl", "--param", "SPEED_MAX=nan", "SPEED_MAX"),
    ("replay", "--speed", "0", "is outside [0.1, 1000.0]"),
    ("replay", "--start", "inf", "'inf' is not a duration"),
])
def test_bad_numbers_in_flags_name_the_flag(tmp_path: Path, command: str, flag: str, value: str, expect: str) -> None:
    before = {"run": ["pool12"], "gcs": ["--sitl"], "sitl": [], "replay": [str(tmp_path)]}[command]
    done = vil(command, *before, f"{flag}={value}", cwd=tmp_path)
    refused(done, f"argument {flag}", expect)
    assert not (tmp_path / "runs").exists()  # nothing started


# --- output paths that cannot be written --------------------------------------------------------

@pytest.mark.parametrize("args, expect", [
    (["run", "pool12", "--json", "/proc/vil/r.json"], "argument --json: cannot write /proc/vil/r.json"),
    (["run", "pool12", "--json", "."], "argument --json: . is a folder"),
    (["run", "pool12", "--out", "/proc/vil"], "argument --out: cannot write in /proc"),
    (["run", "pool12", "--out", "a-file/runs"], "argument --out: a-file is not a folder"),
    (["gcs", "--sitl", "--out", "/proc/vil"], "argument --out: cannot write in /proc"),
    (["report", "RUN", "-o", "a-file"], "argument -o/--out: a-file is not a folder"),
])
def test_unwritable_outputs_are_refused_before_anything_runs(tmp_path: Path, run_folder: Path, args: list[str],
                                                             expect: str) -> None:
    (tmp_path / "a-file").write_text("x")
    done = vil(*[str(run_folder) if a == "RUN" else a for a in args], cwd=tmp_path)
    refused(done, expect)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a-file"]


# --- scenario files: non-finite and out-of-range numbers in the TOML, the GeoJSON, the start ------

def scenario_with(tmp_path: Path, old: str = "", new: str = "", area: dict[str, object] | None = None,
                  start: dict[str, object] | None = None) -> Path:
    text = (MISSIONS / "pool12.toml").read_text()
    assert old in text
    text = text.replace(old, new).replace('"areas/', f'"{MISSIONS}/areas/').replace('"starts/', f'"{MISSIONS}/starts/')
    for key, obj in (("area", area), ("start_config", start)):
        if obj is not None:
            path = tmp_path / f"{key}.geojson"
            path.write_text(json.dumps(obj))  # NaN and Infinity as Python's json writes them
            text = "\n".join(f'{key} = "{path}"' if line.startswith(f"{key} =") else line for line in text.splitlines())
    path = tmp_path / "s.toml"
    path.write_text(text)
    return path


def pool_area() -> dict[str, object]:
    return json.loads((MISSIONS / "areas/pool.geojson").read_text())


def pool_start() -> dict[str, object]:
    return json.loads((MISSIONS / "starts/pool12.geojson").read_text())


def with_vertex(lon: float, lat: float) -> dict[str, object]:
    area = pool_area()
    area["features"][0]["geometry"]["coordinates"][0][1] = [lon, lat]  # type: ignore[index]
    return area


def with_mussel(lon: float, lat: float, battery: float = 0.9) -> dict[str, object]:
    start = pool_start()
    first = start["features"][0]  # type: ignore[index]
    first["geometry"]["coordinates"], first["properties"]["battery"] = [lon, lat], battery
    return start


X0 = 15.44  # the pool, roughly
Y0 = 43.94


@pytest.mark.parametrize("edit, where, expect", [
    (dict(old="pool_threshold = 0.80", new="pool_threshold = nan"), "s.toml", "mission.pool_threshold: nan is not"),
    (dict(old="speed_mps = 0.5", new="speed_mps = inf"), "s.toml", "apad.speed_mps: inf is not a finite number"),
    (dict(old="current_mps = [0.0, 0.0]", new="current_mps = [inf, 0.0]"), "s.toml", "environment.current_mps"),
    (dict(old='duration = "40m"', new="duration = 1e300"), "s.toml", "mission.duration"),
    (dict(area=with_vertex(math.inf, Y0)), "area.geojson", "is not a finite [lon, lat]"),
    (dict(area=with_vertex(math.nan, Y0)), "area.geojson", "is not a finite [lon, lat]"),
    (dict(area=with_vertex(X0, 95.0)), "area.geojson", "not WGS84 degrees"),
    (dict(start=with_mussel(X0 + 0.0001, Y0, battery=math.nan)), "start_config.geojson", "aMussel 1 has nan"),
    (dict(start=with_mussel(X0 + 0.1, Y0)), "start_config.geojson", "aMussel 1 starts 8"),
    (dict(start=with_mussel(math.inf, Y0)), "start_config.geojson", "not WGS84 degrees"),
])
@pytest.mark.parametrize("command", ["run", "gcs"])
def test_bad_scenario_files_are_one_line_naming_file_and_field(tmp_path: Path, command: str, edit: dict[str, object],
                                                               where: str, expect: str) -> None:
    scenario = scenario_with(tmp_path, **edit)  # type: ignore[arg-type]
    args = [str(scenario)] if command == "run" else ["--sitl", "--scenario", str(scenario)]
    done = vil(command, *args, cwd=tmp_path)
    line = refused(done, f"vil {command}: {tmp_path / where}: ", expect)
    assert done.stderr.count("\n") == 1, line
    assert not (tmp_path / "runs").exists()  # no console opened, no run folder made


# --- the console: an address it cannot use -----------------------------------------------------

@pytest.mark.parametrize("address, expect", [
    ("udp:999.1.1.1:5", "cannot open udp:999.1.1.1:5"),
    ("carrier-pigeon", "bad address"),
    ("udpin:127.0.0.1:BUSY", "Address already in use"),
])
def test_gcs_with_an_address_it_cannot_use_says_why_and_never_opens(tmp_path: Path, busy_udp_port: int, address: str,
                                                                    expect: str) -> None:
    done = vil("gcs", "--connect", address.replace("BUSY", str(busy_udp_port)), cwd=tmp_path)
    assert done.stderr.count("\n") == 1 and done.stdout == ""
    refused(done, "vil gcs: ", expect)
    assert list((tmp_path / "runs").iterdir()) == []  # the folder made for it is gone again


def test_sitl_geofence_with_a_vertex_at_infinity_is_refused(tmp_path: Path) -> None:
    fence = tmp_path / "fence.geojson"
    fence.write_text(json.dumps(with_vertex(math.inf, Y0)))
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    done = vil("sitl", "--geofence", str(fence), "--duration", "1s", "--listen", f"udp:127.0.0.1:{port}", cwd=tmp_path)
    assert done.stderr.count("\n") == 1
    refused(done, f"vil sitl: {fence}: ", "is not a finite [lon, lat]")


# --- recorded runs that are damaged --------------------------------------------------------------

@pytest.mark.parametrize("name, text, expect", [
    ("events.jsonl", '{"t_s": 1, "event": "mission_start"}\n{not json\n', "events.jsonl:2: not an event"),
    ("events.jsonl", '{"t_s": NaN, "event": "x"}\n', "events.jsonl:1: t_s nan is not a finite mission time"),
    ("result.json", "{bad", "result.json: not readable JSON"),
])
@pytest.mark.parametrize("command", ["replay", "report"])
def test_damaged_run_files_are_one_line(tmp_path: Path, run_folder: Path, command: str, name: str, text: str,
                                        expect: str) -> None:
    folder = tmp_path / "run"
    folder.mkdir()
    for f in ("gcs.tlog", "result.json", "events.jsonl"):
        (folder / f).write_bytes((run_folder / f).read_bytes())
    (folder / name).write_text(text)
    done = vil(command, str(folder), *(["-o", str(tmp_path / "report")] if command == "report" else []), cwd=tmp_path)
    assert done.stderr.count("\n") == 1
    refused(done, f"vil {command}: {folder / name}", expect)


def test_a_misspelt_flag_is_one_line_naming_the_command_and_the_flag_meant() -> None:
    for args, meant in ((("run", "--stratgy", "greedy"), "--strategy"), (("sweep", "x.toml", "--schduler", "a"),
                                                                       "--scheduler")):
        line = refused(vil(*args), f"vil {args[0]}: error: unrecognized arguments", f"did you mean {meant}?")
        assert f"vil {args[0]} --help" in line


def test_a_replay_start_past_the_runs_end_is_refused_naming_both(run_folder: Path) -> None:
    refused(vil("replay", str(run_folder), "--start", "90min"), "--start 90:00 is past the end", "(01:00)")


def test_a_report_of_a_file_in_a_run_folder_is_the_report_of_that_run(run_folder: Path, tmp_path: Path) -> None:
    done = vil("report", str(run_folder / "result.json"), "--out", str(tmp_path / "report"))
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "report" / "index.html").exists()


def test_a_port_out_of_range_is_named() -> None:
    refused(vil("sitl", "--listen", "udp:127.0.0.1:99999"), "port 99999 is not a port number")
