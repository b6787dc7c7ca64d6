"""Report by exception (`mussel_sim.report_policy`): who reports at a publish, and the fleet that uses it."""

from __future__ import annotations

import numpy as np
import pytest

from apad_sitl.vocabulary import Latch
from mussel_sim.report_policy import LAST_WORDS, ChargerReports, LastWords, ReportByException
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


def test_a_slot_that_latches_asks_for_one_report_per_latch() -> None:
    policy = ReportByException(2, 5 * S, S)
    charger = ChargerReports(policy)
    s = states(D, A)
    assert policy.due(s, None, 0) is None
    charger.slot(apad=1, slot=2, mussel_id=7, latch=int(Latch.CLOSING), row=0)  # closing: not yet
    assert policy.due(s, None, S).tolist() == []
    charger.slot(apad=1, slot=2, mussel_id=7, latch=int(Latch.LATCHED), row=0)
    assert policy.due(s, None, 2 * S).tolist() == [0]  # latched: at the next publish, unchanged or not
    charger.slot(apad=1, slot=2, mussel_id=7, latch=int(Latch.LATCHED), row=0)  # the slot's periodic status
    assert policy.due(s, None, 3 * S).tolist() == []
    charger.slot(apad=1, slot=2, mussel_id=0, latch=int(Latch.OPEN), row=None)
    charger.slot(apad=1, slot=2, mussel_id=7, latch=int(Latch.LATCHED), row=0)  # latched again: again
    assert policy.due(s, None, 4 * S).tolist() == [0]
    charger.slot(apad=1, slot=3, mussel_id=99, latch=int(Latch.LATCHED), row=None)  # not ours: nothing
    assert policy.due(s, None, 6 * S).tolist() == []


def test_last_words_then_silence() -> None:
    words = LastWords()
    s = states(X, A)
    heard = [words.powered(s, 1, None) for _ in range(LAST_WORDS + 2)]
    assert all(h is None for h in heard[:LAST_WORDS]) and heard[LAST_WORDS].tolist() == [1]
    assert words.powered(states(A, A), 1, np.array([0, 1])).tolist() == [0, 1]  # none depleted: all speak


def test_sleepers_between_windows_the_woken_report_and_a_latch_is_still_owed() -> None:
    policy = ReportByException(3, 5 * S, S)
    s = states(A, A, D)
    assert policy.due(s, np.array([2]), 0).tolist() == [2]  # 0 and 1 asleep
    assert policy.due(s, np.array([2]), S).tolist() == []
    assert policy.due(s, np.array([0, 2]), 2 * S).tolist() == [0]  # 0 woke: at once
    assert policy.due(s, np.array([0, 2]), 3 * S).tolist() == []
    ChargerReports(policy).slot(apad=1, slot=1, mussel_id=9, latch=int(Latch.LATCHED), row=2)
    assert policy.due(s, np.array([0, 2]), 4 * S).tolist() == [2]  # the same state, but owed to the charger
