"""The event platform gives lockstep's figures, and its mission log, where the GCS's knowledge is the same on both.

- pool12x2 greedy seed 1: fleets drawn with drift and a planner that picks by distance among aMussels at nearly
  the same distance (greedy's nearest neighbour), where a centimetre of drift the GCS did not know once broke
  a tie the other way (a call-up 7.52 m away against 7.53 m at 30 s, then other routes). The drift is drawn
  draw for draw and the keep-alive's positions handed over when the GCS reads them
  (`mussel_sim.keepalive_positions`).
- bay-capacity keep_alive seed 2: a sleeper speaks only at its wakes, heard at other instants on the two
  platforms; a sleep order's belief used to run the new duty back to the last report, so the two planned on
  different batteries (0.788 and 0.811 at 637 s) and parted there. The order now anchors the belief
  (`gcs.belief.foresight`).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

import vil

# Events about the link's pace, not the mission: each platform asks for telemetry its own way.
LINK_PACE = frozenset({"telemetry_rate", "telemetry_rate_failed"})


def _mission_log(folder: Path) -> list[list[dict[str, Any]]]:
    """The run's events, instant by instant; at one instant in any order (several aPads act at once)."""
    by_instant: dict[float, list[dict[str, Any]]] = {}
    for line in (folder / "events.jsonl").read_text().splitlines():
        event = json.loads(line)
        if event["event"] not in LINK_PACE:
            by_instant.setdefault(event["t_s"], []).append(event)
    return [sorted(events, key=lambda e: json.dumps(e, sort_keys=True)) for _, events in sorted(by_instant.items())]


@pytest.mark.parametrize(("scenario", "strategy", "seed", "duration_s"),
                         [("pool12x2", "greedy", 1, 900.0), ("bay-capacity", "keep_alive", 2, 2400.0)])
def test_the_figures_and_the_mission_log_of_both_platforms_are_the_same(
        scenario: str, strategy: str, seed: int, duration_s: float, tmp_path: Path) -> None:
    runs = {p: vil.run(scenario, strategy=strategy, seed=seed, draw_fleet=True, duration=duration_s, platform=p,
                       out=f"{tmp_path}/{p}") for p in ("lockstep", "event")}
    lock, event = (runs[p].raw.to_json() for p in ("lockstep", "event"))
    assert event["platform"] == "event" and lock["platform"] == "lockstep"
    assert event["uptime"] == lock["uptime"]
    assert event["cycles"] == lock["cycles"] and event["cost_m"] == pytest.approx(lock["cost_m"], abs=0.01)
    logs = [_mission_log(runs[p].folder) for p in ("lockstep", "event")]
    assert len(logs[0]) > 20 and logs[1] == logs[0]
