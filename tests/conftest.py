"""Shared test setup: deterministic environment for every layer."""

from __future__ import annotations

import compileall
import os
from pathlib import Path

import pytest

# NO_COLOR changes Textual's rendering and breaks snapshots (NOTES.md).
os.environ.pop("NO_COLOR", None)

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("vil", "missiontime", "acoustic", "mavlink_dialect", "mussel_sim", "apad_sitl", "gcs")


def pytest_configure(config: pytest.Config) -> None:
    """Bytecode for the project's packages, written once before the workers start. Hundreds of tests start
    `vil`, SITL and modem processes; where PYTHONDONTWRITEBYTECODE is set (as `make` expects, see its
    compileall of mavlink_dialect) each of them compiled every module it imports again, ~0.4 s a start.
    compileall writes .pyc regardless, only for sources newer than theirs (git ignores __pycache__/)."""
    if hasattr(config, "workerinput"):  # an xdist worker: the controller has compiled them
        return
    for package in PACKAGES:
        compileall.compile_dir(ROOT / package, quiet=2)
