"""Report by exception (`mussel_sim.report_policy`): who reports at a publish, and the fleet that uses it."""

from __future__ import annotations

import numpy as np
import pytest

from mussel_sim.report_policy import ReportByException
from mussel_sim.vocabulary import MusselState

S = 1_000_000
A, D, F, X = (np.uint8(s) for s in (MusselState.ACTIVE, MusselState.DOCKED, MusselState.FLOATING,
                                     MusselState.DEPLETED))


def states(*codes: np.uint8) -> np.ndarray:
    out = np.array(codes, np.uint8)
    out.flags.writeable = False  # as the fleet's state arrays are
    return out


def test_everyone_at_a_window_start_only_the_changed_between() -> None:
    policy = ReportByException(3, 5 * S, S)
    first = states(A, A, D)
    assert policy.due(first, None, 0) is None  # a window starts: all
    assert policy.due(first, None, 1 * S).tolist() == []  # the very state reported
    changed = states(A, F, D)
    assert policy.due(changed, None, 2 * S).tolist() == [1]  # the one that changed, at once
    assert policy.due(changed, None, 3 * S).tolist() == []
    assert policy.due(states(A, F, D), None, 4 * S).tolist() == []  # equal, though another array
    assert policy.due(changed, None, 5 * S) is None
    assert policy.held == 3 + 2 + 3 + 3


def test_one_that_starts_speaking_reports_at_once_and_the_depleted_every_publish() -> None:
    policy = ReportByException(3, 5 * S, S)
    s = states(A, A, X)
    assert policy.due(s, np.array([0, 2]), 0).tolist() == [0, 2]  # row 1 asleep (not speaking)
    assert policy.due(s, np.array([0, 1, 2]), S).tolist() == [1, 2]  # 1 woke; 2's last words
    assert policy.due(s, np.array([0, 1, 2]), 2 * S).tolist() == [2]
    assert policy.due(s, np.array([0, 1]), 3 * S).tolist() == []  # 2 fell silent (its radio off)


def test_keep_alive_zero_is_every_speaking_aMussel_every_publish() -> None:
    policy = ReportByException(2, 0, S)
    s = states(A, A)
    assert policy.due(s, None, 0) is None and policy.due(s, None, S) is None
    assert policy.due(s, np.array([1]), 2 * S).tolist() == [1]
    with pytest.raises(ValueError, match="keep-alive"):
        ReportByException(2, -1, S)


def test_the_window_follows_mission_time_not_the_start_of_the_policy() -> None:
    policy = ReportByException(2, 5 * S, S)  # a resumed mission's first publish at 12 s
    s = states(A, A)
    assert policy.due(s, None, 12 * S).tolist() == [0, 1]  # never reported: everyone
    assert policy.due(s, None, 13 * S).tolist() == [] and policy.due(s, None, 14 * S).tolist() == []
    assert policy.due(s, None, 15 * S) is None
