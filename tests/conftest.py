"""Shared test setup: deterministic environment for every layer."""

from __future__ import annotations

import compileall
import os
import sys
import tomllib
from collections.abc import Iterator
from pathlib import Path

import pytest

# NO_COLOR changes Textual's rendering and breaks snapshots (NOTES.md).
os.environ.pop("NO_COLOR", None)

ROOT = Path(__file__).resolve().parents[1]
# The project's top-level packages, as pyproject.toml lists them (the Makefile compiles the same).
PACKAGES = sorted({p.split(".")[0] for p in
                   tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"]})


def pytest_configure(config: pytest.Config) -> None:
    """Bytecode for the project's packages, written once before the workers start. Hundreds of tests start
    `vil`, SITL and modem processes; where PYTHONDONTWRITEBYTECODE is set (as `make` expects, see its
    compileall) each of them compiled every module it imports again, ~0.4 s a start, and a source
    changed since `make` is compiled once here instead of in every process.
    compileall writes .pyc regardless, only for sources newer than theirs (git ignores __pycache__/)."""
    if hasattr(config, "workerinput"):  # an xdist worker: the controller has compiled them
        return
    for package in PACKAGES:
        compileall.compile_dir(ROOT / package, quiet=2)


@pytest.fixture(autouse=True)
def _strategy_registry_as_shipped() -> Iterator[None]:
    """A strategy a test loads (a file or an entry point, through `plugins.load_strategy`) is dropped from
    the registries when the test ends: a later test on the same worker sees the shipped strategies only."""
    yield
    base = sys.modules.get("gcs.strategies.base")
    plugins = sys.modules.get("gcs.strategies.plugins")
    if base is None or plugins is None:  # nothing imported, nothing registered
        return
    for name in set(plugins.SOURCES):
        base.STRATEGIES.pop(name, None)
        base.TRAITS.pop(name, None)
    plugins.SOURCES.clear()
