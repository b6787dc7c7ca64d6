"""Each wait of the loop declares when time alone could turn it true (`gcs.loop.wake_times`); lockstep looks
at every poll anyway, so with the check on (`gcs.loop.wait_check`) it holds every declaration to what it sees.
Whole missions over real MAVLink bytes, with the check on: no wait turns true undeclared; and a declaration
made wrong on purpose is caught (the check can fail)."""

from __future__ import annotations

import pytest

from gcs.loop import phases, wait_check
from gcs.loop.wait_check import WaitDeclarationError
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
