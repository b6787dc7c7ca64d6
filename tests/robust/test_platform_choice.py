"""Choosing the platform (issue 37): what is about the wire is refused on the event platform in one line,
exit 2, before anything runs, from `vil run`, `vil.run` and a sweep spec alike; a run names the platform
it ran on in result.json and its summary, and an event run writes no .tlog."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import vil
from gcs.sweep.spec import SpecError, load_spec

ROOT = Path(__file__).resolve().parents[2]
VIL = [sys.executable, "-m", "gcs.cli", "run"]
WALL_TIMEOUT_S = 120.0
ENV = {**{k: v for k, v in os.environ.items() if k not in ("COLUMNS", "VIL_SIGNING_KEY")}, "PYTHONPATH": str(ROOT)}

WIRE_FLAGS = [
    (["--loss", "0.1"], "loss"),
    (["--latency", "200ms"], "latency"),
    (["--jitter", "50ms"], "jitter"),
    (["--duplicate", "0.05"], "duplicate"),
    (["--outage", "10s:20s"], "outage"),
    (["--fail-apad", "1:10s"], "fail-apad"),
    (["--proxy"], "proxy"),
    (["--resume"], "resume"),
]


def _vil_run(args: list[str], cwd: Path, env: dict[str, str] = ENV) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*VIL, *args], cwd=cwd, capture_output=True, text=True, timeout=WALL_TIMEOUT_S, env=env)


@pytest.mark.parametrize("flag, name", WIRE_FLAGS, ids=[n for _, n in WIRE_FLAGS])
def test_a_wire_flag_on_the_event_platform_is_one_line_exit_2(tmp_path: Path, flag: list[str], name: str) -> None:
    done = _vil_run(["pool12", "--platform", "event", *flag], tmp_path)
    assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr
    assert done.stderr.startswith(f"vil run: {name} ") and "--platform lockstep" in done.stderr
    assert not (tmp_path / "runs").exists()  # nothing started, no folder made


def test_a_signing_key_from_the_environment_is_refused_too(tmp_path: Path) -> None:
    done = _vil_run(["pool12", "--platform", "event"], tmp_path, {**ENV, "VIL_SIGNING_KEY": "secret"})
    assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr
    assert "$VIL_SIGNING_KEY" in done.stderr and "--platform lockstep" in done.stderr


def test_an_unknown_platform_is_argparse_s_line(tmp_path: Path) -> None:
    done = _vil_run(["pool12", "--platform", "discrete"], tmp_path)
    assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr
    assert "unknown platform 'discrete'; choose lockstep or event" in done.stderr


@pytest.mark.parametrize("kwargs", [{"loss": 0.2}, {"signing_key": "secret"}, {"proxy": True}, {"resume": True},
                                    {"fail_apads": ["1:10s"]}])
def test_vil_run_refuses_the_same_in_one_line(tmp_path: Path, kwargs: dict[str, object]) -> None:
    with pytest.raises(vil.Error, match="--platform lockstep") as caught:
        vil.run("pool12", platform="event", out=tmp_path / "runs", **kwargs)  # type: ignore[arg-type]
    assert "\n" not in str(caught.value)
    assert not (tmp_path / "runs").exists()


def test_vil_run_names_a_bad_platform(tmp_path: Path) -> None:
    with pytest.raises(vil.Error, match="platform: unknown platform 'fast'"):
        vil.run("pool12", platform="fast", out=tmp_path)


def test_a_sweep_spec_names_its_platform_or_is_refused(tmp_path: Path) -> None:
    spec = tmp_path / "s.toml"
    spec.write_text('[sweep]\nscenarios = ["pool12"]\nplatform = "event"\n')
    assert str(load_spec(spec).platform) == "event"
    spec.write_text('[sweep]\nscenarios = ["pool12"]\n')
    assert str(load_spec(spec).platform) == "lockstep"
    spec.write_text('[sweep]\nscenarios = ["pool12"]\nplatform = "ideal"\n')
    with pytest.raises(SpecError, match=r"sweep\.platform: unknown platform 'ideal'"):
        load_spec(spec)


@pytest.mark.sitl
def test_an_event_run_names_its_platform_and_writes_no_tlog(tmp_path: Path) -> None:
    done = _vil_run(["pool12", "--platform", "event", "--duration", "5min", "--json", "r.json"], tmp_path)
    assert done.returncode == 0, done.stderr
    result = json.loads((tmp_path / "r.json").read_text())
    assert result["platform"] == "event"
    folder = tmp_path / result["out_dir"]
    assert json.loads((folder / "result.json").read_text())["platform"] == "event"
    assert not list(folder.glob("*.tlog"))
    assert (folder / "events.jsonl").stat().st_size > 0 and (folder / "traces.npz").is_file()
    assert "on the event platform" in done.stdout and "no .tlog" in done.stdout
    assert "--platform event" in (folder / "command.txt").read_text()
