"""A recorded run for replay, snapshot and report tests: pool12 in lockstep, stopped at a fixed time.

The operator stop (a scheduler task at exactly STOP_AT_S of mission time) makes the recording
deterministic and short, whatever the scenario's mission length.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from gcs.loop.energy_sharing import LoopControl
from gcs.mission.world import MISSION_TELEMETRY_HZ, headless_world
from gcs.scenario.reader import load_scenario

MISSIONS = Path(__file__).resolve().parents[2] / "missions"
STOP_AT_S = 240.0


def record_run(out_dir: Path, stop_at_s: float = STOP_AT_S) -> Path:
    scenario = load_scenario(MISSIONS / "pool12.toml")
    world = headless_world(scenario, out_dir)
    control = LoopControl()
    try:
        world.clock.scheduler.every(stop_at_s, lambda now_us: setattr(control, "stop", True), "stop",
                                    round(stop_at_s * 1e6))
        world.api.wait_apad(timeout_s=10.0)
        world.api.set_telemetry_rates(MISSION_TELEMETRY_HZ)
        world.mission_loop(control).run()
    finally:
        world.close()
    (out_dir / "console.json").write_text(f'{{"scenario_path": "{MISSIONS / "pool12.toml"}"}}\n')
    return out_dir


@pytest.fixture(scope="session")
def recorded_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return record_run(tmp_path_factory.mktemp("run") / "pool12-cautious-seed1")
