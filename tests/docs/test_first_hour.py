"""What the README and docs say in prose to someone in their first hour (issue 39), held to what the code and
Python do: whose `vil` the examples run, the runtime-only install, the longest duration, the script beside a
folder named `vil`, the main guard for `vil.sweep`, the cadence of `strategy_failed`. The commands themselves
are the registry's (doc_registry.py)."""

from __future__ import annotations

import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
from doc_examples import blocks, kind
from doc_harness import ROOT

README = ROOT / "README.md"


def prose(path: Path) -> str:
    """The file's text with its line breaks as spaces (a claim may wrap)."""
    return " ".join(path.read_text(encoding="utf-8").split())


def test_the_quick_start_comes_first_and_then_whose_vil_the_examples_run() -> None:
    """After `make run`, `vil --help` was "command not found" and `python missions/listing1.py` the system's
    Python: before the first `vil` example the README says to activate .venv or name .venv/bin/vil."""
    first, *rest = [b for b in blocks(README) if kind(b) == "commands"]
    assert [line.split("#")[0].strip() for line in first.lines] == ["make run", "make test"]
    text = README.read_text(encoding="utf-8").splitlines()
    before = " ".join(text[first.line:next(b.line for b in rest if any(" vil " in f" {x}" for x in b.lines))])
    before = " ".join(before.split())
    assert "source .venv/bin/activate" in before and "`.venv/bin/vil`" in before and "`.venv/bin/python`" in before


def test_the_runtime_only_install_is_pyprojects_dependencies_pinned_as_make_pins_them() -> None:
    line = "python3 -m venv .venv && .venv/bin/pip install -c requirements.lock -e ."
    assert f"`{line}`" in prose(README)
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    def name(requirement: str) -> str:  # PEP 503: tomli-w and tomli_w are one package
        return re.sub(r"[-_.]+", "-", re.split(r"[=<>\[ ]", requirement, maxsplit=1)[0]).lower()

    pinned = {name(p) for p in (ROOT / "requirements.lock").read_text().splitlines() if p.strip()
              and not p.startswith("#")}
    runtime = {name(d) for d in project["dependencies"]}
    assert runtime <= pinned, runtime - pinned
    assert "-e ." in line and "[" not in line  # no extras: not test's pytest/playwright, not interop's MAVProxy/vtk
    make = (ROOT / "Makefile").read_text()
    assert "-c requirements.lock -e '.[test,interop]'" in make  # what `make` adds over it


def test_the_longest_duration_the_docs_and_help_name_is_the_readers(capsys: pytest.CaptureFixture[str]) -> None:
    """The README said `--duration 7d` was a week at most; --help said 90 days; 8 days ran."""
    from gcs.cli.main import main
    from gcs.scenario.reader import MAX_DURATION_S
    from missiontime.durations import parse_duration_s

    days = MAX_DURATION_S / 86400
    assert f"up to {days:g} days" in prose(README) and "a week at most" not in prose(README)
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    assert f"up to {days:g} days" in " ".join(capsys.readouterr().out.split())
    assert parse_duration_s(f"{days:g}d") == MAX_DURATION_S
    with pytest.raises(ValueError):
        parse_duration_s(f"{days + 1:g}d")


def test_a_script_beside_a_folder_named_vil_fails_as_the_readme_says(tmp_path: Path) -> None:
    """Python takes the script's folder's `vil` (an empty namespace package) before an editable install, which
    is looked up after every folder on the path (as `make` and the runtime-only install put it); the README
    quotes what that prints and says the package cannot catch it. (With PYTHONPATH naming the repository the
    regular package there wins: the test runs without it, as a user's script does.)"""
    (tmp_path / "vil").mkdir()
    (tmp_path / "study.py").write_text('import vil\n\nvil.run("pool12")\n')
    done = subprocess.run([sys.executable, "study.py"], cwd=tmp_path, capture_output=True, text=True, timeout=60,
                          env={"PATH": "/usr/bin:/bin"})
    quoted = "module 'vil' has no attribute 'run'"
    assert done.returncode == 1 and done.stderr.splitlines()[-1] == f"AttributeError: {quoted}"
    text = prose(README)
    assert f"`{quoted}`" in text and "nothing inside the package can catch it" in text


def test_the_main_guard_is_said_where_vil_sweep_is_documented() -> None:
    import vil

    guard = 'if __name__ == "__main__":'
    assert guard in prose(ROOT / "docs/sweeps.md") and guard in prose(README)
    assert guard in " ".join((vil.sweep.__doc__ or "").split())
    assert guard.replace('"', '\\"') in (ROOT / "docs/examples/vil-notebook.ipynb").read_text()


def test_strategy_failed_is_documented_at_the_counts_it_is_logged() -> None:
    """The loop logs it at the 1st, 10th, 100th, ... failure (gcs/loop/phases.py); only a docstring said so."""
    from gcs.loop import phases

    assert "1st, 10th, 100th" in " ".join((phases.strategy_route.__doc__ or "").split())
    assert "`strategy_failed`" in prose(ROOT / "docs/strategies.md")
    assert "logged at its 1st, 10th, 100th, 1,000th, ... failure only" in prose(ROOT / "docs/strategies.md")
