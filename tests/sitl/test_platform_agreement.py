"""The event platform gives lockstep's figures where the GCS's knowledge is the same on both: fleets drawn
with drift and a planner that picks by distance among aMussels at nearly the same distance (greedy's nearest
neighbour), where a centimetre of drift the GCS did not know once broke a tie the other way (pool12x2 seed 1:
a call-up 7.52 m away against 7.53 m at 30 s, then other routes). The drift is drawn draw for draw and the
keep-alive's positions handed over when the GCS reads them (`mussel_sim.keepalive_positions`)."""

from __future__ import annotations

import pytest

import vil


@pytest.mark.parametrize(("scenario", "seed"), [("pool12x2", 1)])
def test_the_figures_of_both_platforms_are_the_same(scenario: str, seed: int, tmp_path: object) -> None:
    runs = {p: vil.run(scenario, strategy="greedy", seed=seed, draw_fleet=True, duration=900.0, platform=p,
                       out=f"{tmp_path}/{p}").raw.to_json() for p in ("lockstep", "event")}
    lock, event = runs["lockstep"], runs["event"]
    assert event["platform"] == "event" and lock["platform"] == "lockstep"
    assert event["uptime"] == lock["uptime"]
    assert event["cycles"] == lock["cycles"] and event["cost_m"] == pytest.approx(lock["cost_m"], abs=0.01)
