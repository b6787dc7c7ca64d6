"""Strategies from outside the package (issue 22): a file with `vil run` and `vil sweep` (a local
cluster, and a separate scheduler with workers that get the file from Dask), an installed entry
point, and each kind of bad strategy: one line and exit 2 before the mission, or, once a mission
runs, an event and a mission that goes on."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pandas as pd
import pytest
from testkit import dask_processes

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "docs" / "examples" / "slack_first.py"
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}
pytestmark = [pytest.mark.sitl]
SHORT = ["--duration", "8m"]  # pool12 plans at the start and again at 7 min


def vil(cwd: Path, *args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "gcs.cli", *args], cwd=cwd, capture_output=True, text=True,
                          timeout=300, env=env or ENV)


def events(folder: Path) -> list[dict[str, object]]:
    return [json.loads(line) for line in (folder / "events.jsonl").read_text().splitlines()]


def test_a_strategy_in_a_file_outside_the_repository_runs_under_its_name(tmp_path: Path) -> None:
    shutil.copy(EXAMPLE, tmp_path / "mine.py")
    done = vil(tmp_path, "run", "pool12", "--strategy", "mine.py:slack_first", *SHORT)
    assert done.returncode == 0, done.stderr
    folder = tmp_path / "runs" / "pool12-slack_first-seed1-run1"
    result = json.loads((folder / "result.json").read_text())
    assert result["strategy"] == "slack_first" and "pool12 slack_first s1" in done.stdout
    plans = [e for e in events(folder) if e["event"] == "plan_collection"]
    assert plans and all(e["strategy"] == "slack_first" for e in plans)
    assert not [e for e in events(folder) if e["event"] == "strategy_failed"]


def test_a_scenario_names_a_strategy_file_from_its_own_folder(tmp_path: Path) -> None:
    (tmp_path / "site").mkdir()
    shutil.copy(EXAMPLE, tmp_path / "site" / "mine.py")
    text = (ROOT / "missions" / "pool12.toml").read_text().replace('collect_strategy = "cautious"',
                                                                    'collect_strategy = "mine.py:slack_first"')
    text = text.replace('"areas/', f'"{ROOT}/missions/areas/').replace('"starts/', f'"{ROOT}/missions/starts/')
    assert "mine.py:slack_first" in text
    (tmp_path / "site" / "mine.toml").write_text(text)
    done = vil(tmp_path, "run", "site/mine.toml", "--duration", "1m")
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "runs" / "mine-slack_first-seed1-run1" / "result.json").is_file()  # a copy: its own name


SPEC = """
[sweep]
scenarios = ["pool12"]
strategies = ["strategies/mine.py:slack_first", "cautious"]
seeds = "1-2"
[set]
mission.duration = "3m"
"""


def _sweep_rows(out: Path) -> pd.DataFrame:
    rows = pd.read_parquet(out / "results.parquet")
    assert sorted(set(rows["strategy"])) == ["cautious", "slack_first"] and len(rows) == 4
    return rows.drop(columns=[c for c in rows.columns if c.endswith("wall_s")])


def test_a_sweep_of_a_strategy_file_on_a_local_cluster_and_on_separate_workers(tmp_path: Path) -> None:
    """The local cluster's workers are processes that load the file from its path; the separate ones
    (their folder elsewhere, the file nowhere on their path) get it from the client (upload_file)."""
    (tmp_path / "spec" / "strategies").mkdir(parents=True)
    shutil.copy(EXAMPLE, tmp_path / "spec" / "strategies" / "mine.py")
    (tmp_path / "spec" / "sweep.toml").write_text(SPEC)
    # One worker process each side: a worker loads or is sent the file like every other (the suite's time).
    local = vil(tmp_path, "sweep", "spec/sweep.toml", "--out", "local", "--workers", "1", "--no-report")
    assert local.returncode == 0, local.stderr + local.stdout
    (tmp_path / "dask").mkdir()
    with dask_processes(tmp_path / "dask", workers=1) as address:
        remote = vil(tmp_path, "sweep", "spec/sweep.toml", "--out", "remote", "--scheduler", address, "--no-report")
    assert remote.returncode == 0, remote.stderr + remote.stdout
    pd.testing.assert_frame_equal(_sweep_rows(tmp_path / "local"), _sweep_rows(tmp_path / "remote"))
    assert list((tmp_path / "dask").glob("worker*/**/vil_strategy_mine_*.py"))  # what Dask shipped to the workers


def test_a_strategy_from_an_installed_packages_entry_point(tmp_path: Path) -> None:
    site = tmp_path / "site"
    pip = subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--no-index", "--target",
                          str(site), str(_slackpkg_wheel(tmp_path))], capture_output=True, text=True, timeout=300)
    assert pip.returncode == 0, pip.stderr
    env = {**ENV, "PYTHONPATH": f"{ROOT}{os.pathsep}{site}"}
    done = vil(tmp_path, "run", "pool12", "--strategy", "slack", *SHORT, env=env)
    assert done.returncode == 0, done.stderr
    result = json.loads((tmp_path / "runs" / "pool12-slack-seed1-run1" / "result.json").read_text())
    assert result["strategy"] == "slack"
    bad = vil(tmp_path, "run", "pool12", "--strategy", "stranger", *SHORT, env=env)  # planned before the start
    assert bad.returncode == 2 and "planned aMussel 9999, which is not a candidate" in bad.stderr, bad.stderr


def _slackpkg_wheel(folder: Path) -> Path:
    """The package slackpkg as a wheel, its two strategies entry points of vil.strategies. Written here, not built
    from a pyproject.toml: pip builds a source tree in an isolated environment it first installs setuptools
    into (3 s, and the package index); a wheel it only unpacks, entry_points.txt and all, as it does any."""
    wheel = folder / "slackpkg-0.1-py3-none-any.whl"
    info = "slackpkg-0.1.dist-info"
    files = {
        "slackpkg/__init__.py": EXAMPLE.read_text(),
        "slackpkg/stranger.py": "def plan(inp, weights):\n    return {a: [9999] for a in inp.apads}\n",
        f"{info}/METADATA": "Metadata-Version: 2.1\nName: slackpkg\nVersion: 0.1\n",
        f"{info}/WHEEL": "Wheel-Version: 1.0\nGenerator: tests\nRoot-Is-Purelib: true\nTag: py3-none-any\n",
        f"{info}/entry_points.txt": ("[vil.strategies]\nslack = slackpkg:slack_first\n"
                                     "stranger = slackpkg.stranger:plan\n"),
    }
    with zipfile.ZipFile(wheel, "w") as archive:
        for name, text in files.items():
            archive.writestr(name, text)
        archive.writestr(f"{info}/RECORD", "".join(f"{name},,\n" for name in [*files, f"{info}/RECORD"]))
    return wheel


BAD = {
    "no_function.py": ("", "mine.py:slack_first", "no function 'slack_first'"),
    "signature.py": ("def slack_first(inp):\n    return {}\n", "mine.py:slack_first", "must take two arguments"),
    "stranger.py": ("def slack_first(inp, weights):\n    return {a: [9999] for a in inp.apads}\n",
                    "mine.py:slack_first", "planned aMussel 9999, which is not a candidate"),
    "raises_at_once.py": ("def slack_first(inp, weights):\n    raise RuntimeError('boom')\n",
                          "mine.py:slack_first", "raised RuntimeError: boom"),
    "import_fails.py": ("import no_such_module_here\n", "mine.py:slack_first", "importing it failed"),
    "module_named_like_the_library.py": ("", "heapq.py:heappush", "no such strategy file"),  # not the stdlib's
}


def test_each_bad_strategy_is_one_line_and_exit_2_before_the_mission(tmp_path: Path) -> None:
    (tmp_path / "empty").mkdir()
    cases = [("missing file", tmp_path / "empty", "nowhere.py:slack_first", "no such strategy file"),
             ("misspelt name", tmp_path / "empty", "cautios", "did you mean cautious?")]
    for name, (body, spec, words) in BAD.items():
        (tmp_path / name).mkdir()
        (tmp_path / name / "mine.py").write_text(body)
        cases.append((name, tmp_path / name, spec, words))
    for name, cwd, spec, words in cases:
        done = vil(cwd, "run", "pool12", "--strategy", spec, "--duration", "1m")
        assert done.returncode == 2, (name, done.stderr)
        one_line = done.stderr.count("\n") == 1 and "Traceback" not in done.stderr
        assert words in done.stderr and one_line, (name, done.stderr)
        assert not (cwd / "runs").exists(), name  # nothing started


def test_a_strategy_that_fails_mid_mission_is_an_event_and_the_mission_goes_on(tmp_path: Path) -> None:
    """It plans on the start (every aMussel a candidate) and raises once fewer are: the cautious
    strategy plans those steps (docs/strategies.md), each failure is an event."""
    (tmp_path / "mine.py").write_text(EXAMPLE.read_text() + (
        "\n\ndef picky(inp: PlanInput, weights: CostWeights) -> Plan:\n"
        "    if len(inp.mussel_ids) < 12:\n"
        "        raise ValueError('fewer than twelve candidates')\n"
        "    return slack_first(inp, weights)\n"))
    done = vil(tmp_path, "run", "pool12", "--strategy", "mine.py:picky", *SHORT)
    assert done.returncode == 0, done.stderr
    folder = tmp_path / "runs" / "pool12-picky-seed1-run1"
    failed = [e for e in events(folder) if e["event"] == "strategy_failed"]
    assert failed and all("fewer than twelve candidates" in str(e["why"]) and e["instead"] == "cautious"
                          for e in failed)
    assert [e["failures"] for e in failed] == [1, 10, 100, 1000][:len(failed)]  # the log is bounded
    result = json.loads((folder / "result.json").read_text())
    assert result["happened"]["strategy_failures"] >= len(failed)
    assert "planning step the strategy failed" in " ".join(done.stdout.split())
    assert any(e["event"] == "docked" for e in events(folder))  # the mission went on: aMussels were collected
    assert json.loads((folder / "result.json").read_text())["cycles"] >= 1


def test_vil_gcs_takes_a_strategy_from_a_file_and_refuses_a_bad_one_before_the_console_opens(tmp_path: Path) -> None:
    (tmp_path / "mine.py").write_text("def slack_first(inp, weights):\n    return {a: [9999] for a in inp.apads}\n")
    for spec, words in (("mine.py:slack_first", "planned aMussel 9999, which is not a candidate"),
                        ("mine.py:other", "no function 'other'"), ("cautios", "did you mean cautious?")):
        done = vil(tmp_path, "gcs", "--sitl", "--strategy", spec)
        assert done.returncode == 2 and words in done.stderr and done.stderr.count("\n") == 1, done.stderr
