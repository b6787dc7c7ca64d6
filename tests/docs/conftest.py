"""Fixtures of the doc-example tests (tests/docs): the recorded runs several examples read, and `check`,
which runs one registry run in a `Work` folder and checks that it ran every command it is registered for."""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "interop"))  # interop_procs: the MAVProxy helpers

from doc_harness import Work, shared_folder
from doc_registry import REGISTRY, commands_of

RECORDED = "vil run pool12 --strategy greedy,cautious --duration 2m"  # two runs: runs/latest, and A and B to compare


@pytest.fixture(scope="session")
def recorded_runs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder whose runs/ holds two short recorded runs (pool12-greedy-seed1-run1,
    pool12-cautious-seed1-run1) and latest; made once per test run, whatever the number of workers.
    Examples copy runs/ into their own folder before they run."""
    with shared_folder(tmp_path_factory, "doc-recorded-runs") as (folder, to_make):
        if to_make:
            work = Work(folder, False, lambda command, full: command, lambda name: None)
            work.sh(RECORDED)
    return folder


@pytest.fixture
def check(tmp_path: Path, request: pytest.FixtureRequest) -> Callable[[Callable[[Work], None], bool], None]:
    def run(function: Callable[[Work], None], full: bool) -> None:
        asked: list[str] = []

        def line(command: str, full_run: bool) -> str:
            assert command in REGISTRY, f"{command!r} is run by {function.__name__} but has no registry entry"
            asked.append(command)
            return REGISTRY[command].line(command, full_run)

        function(Work(tmp_path, full, line, request.getfixturevalue))
        missing = [c for c in commands_of(function) if c not in asked]
        assert missing == [], f"{function.__name__} is registered for {missing} but did not run them"

    return run
