"""Each wait of the loop declares when time alone could turn it true (`gcs.loop.wake_times`); lockstep looks
at every poll anyway, so with the check on (`gcs.loop.wait_check`) it holds every declaration to what it sees.
Whole missions over real MAVLink bytes, with the check on: no wait turns true undeclared; and a declaration
made wrong on purpose is caught (the check can fail)."""

from __future__ import annotations

import pytest

from gcs.loop import phases, wait_check
from gcs.loop.fleet_knowledge import FleetKnowledge
from gcs.loop.wait_check import WaitDeclarationError
from gcs.loop.wake_times import pool_look_by
from gcs.mission.headless import run_mission
from gcs.scenario.reader import load_scenario


@pytest.fixture
def checked(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(wait_check, "ENABLED", True)


@pytest.mark.parametrize(("name", "strategy"), [("pool12x2", "cautious"), ("pool12x2", "rolling"),
                                                ("pool12x2", "keep_alive"), ("bay24-acoustic", "greedy")])
def test_every_wait_of_a_mission_turns_true_on_news_or_at_its_declared_time(checked: None, name: str,
                                                                            strategy: str) -> None:
    result = run_mission(load_scenario(name).with_overrides(strategy=strategy, duration_s=1200.0))
    assert result.cycles > 0  # the waits were waited: collections ran to their end


@pytest.mark.parametrize(("name", "declaration", "wrong"), [
    ("pool12x2", "pool_look_by", lambda knows: 1e9),
    ("pool12", "all_charged_look_by", lambda knows, ids, strategy: 1e9),
])
def test_a_wait_declared_wrong_is_caught(checked: None, monkeypatch: pytest.MonkeyPatch, name: str,
                                         declaration: str, wrong: object) -> None:
    monkeypatch.setattr(phases, declaration, wrong)
    with pytest.raises(WaitDeclarationError, match="nothing heard since the last look"):
        run_mission(load_scenario(name).with_overrides(duration_s=1200.0))


def test_the_idle_waits_look_by_is_not_stuck_in_the_past_once_an_amussel_is_believed_empty(
        checked: None, monkeypatch: pytest.MonkeyPatch) -> None:
    """bay24-acoustic with no charging: aMussels under water run flat and stay ACTIVE in the table, silent.
    A platform that wakes at `look_by` must find it ahead of the clock, not an instant long gone (it
    would wake at every instant)."""
    seen: list[tuple[float, float | None]] = []

    def recorded(knows: FleetKnowledge) -> float | None:
        at = pool_look_by(knows)
        seen.append((knows.clock.time(), at))
        return at

    monkeypatch.setattr(phases, "pool_look_by", recorded)
    result = run_mission(load_scenario("bay24-acoustic").with_overrides(strategy="none", duration_s=2400.0))
    assert any(m.first_depleted_s is not None for m in result.mussels)  # some ran flat while it waited
    past = sum(1 for now_s, at in seen if at is not None and at < now_s)
    assert seen and past <= 0.05 * len(seen), f"{past} of {len(seen)} looks declared an instant already past"
