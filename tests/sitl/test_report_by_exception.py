"""Report by exception over a whole lockstep mission (the real SITL aPad, the fleet, the GCS, MAVLink bytes):
the fleet sends a third of the statuses, and nothing the mission decides or meters moves."""

from __future__ import annotations

import dataclasses
from dataclasses import replace

import pytest

from gcs.mission.headless import run_mission
from gcs.results.run_result import RunResult
from gcs.scenario.reader import load_scenario

pytestmark = pytest.mark.sitl


def mission(keepalive_s: float) -> RunResult:
    scenario = load_scenario("pool12").with_overrides(duration_s=900.0)
    return run_mission(replace(scenario, fleet=replace(scenario.fleet, status_keepalive_s=keepalive_s)))


def test_a_mission_reported_by_exception_decides_and_meters_as_one_reported_every_step() -> None:
    every, by_exception = mission(0.0), mission(5.0)
    assert by_exception.messages["fleet_sent"] < 0.6 * every.messages["fleet_sent"]
    # The GCS runs the batteries forward between reports: the same call-ups, dockings and releases.
    assert by_exception.uptime == every.uptime and by_exception.cycles == every.cycles
    assert [m.uptime_pct for m in by_exception.mussels] == [m.uptime_pct for m in every.mussels]
    assert by_exception.cost_m == pytest.approx(every.cost_m, abs=0.5)  # positions heard up to 5 s before
    # The aPad's charger meters by the reports it hears while a slot holds an aMussel: the fleet reports
    # one as its slot latches and as it lets go, so the energy passed is what a report every step gave.
    def energy(r: RunResult) -> list[tuple[float, float]]:
        return [(a["passed_wh"], a["drawn_wh"]) for a in dataclasses.asdict(r)["apads"]]
    assert energy(by_exception) == energy(every) and energy(every)[0][0] > 5.0
