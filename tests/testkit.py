"""Small helpers every test folder uses (tests/ is on the import path through its conftest)."""

from __future__ import annotations

import json
import socket
from pathlib import Path
from typing import Any

MISSIONS = Path(__file__).resolve().parents[1] / "missions"


def free_udp_port() -> int:
    """A UDP port nobody on 127.0.0.1 is bound to right now."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def read_jsonl(path: Path) -> list[dict[str, Any]]:
    """Every line of an event log."""
    return [json.loads(line) for line in path.read_text().splitlines()]


def scenario_variant(name: str, out: Path, replace: dict[str, str]) -> Path:
    """missions/NAME.toml written to `out` with each `replace` key swapped for its value, its area
    and start files still found (paths made absolute)."""
    text = (MISSIONS / f"{name}.toml").read_text()
    text = text.replace('"areas/', f'"{MISSIONS}/areas/').replace('"starts/', f'"{MISSIONS}/starts/')
    for old, new in replace.items():
        assert old in text, f"{old!r} not in {name}.toml"
        text = text.replace(old, new)
    out.write_text(text)
    return out
