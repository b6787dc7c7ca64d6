"""The report's sharings of a swarm (partition.png): each re-share with the aMussels that joined it as they
were first heard folded in, at its own time, and older or damaged events left out."""

from __future__ import annotations

from gcs.records.events import Event
from gcs.report.maps import reshares


def test_joins_fold_into_the_sharing_before_them_which_keeps_its_own_time() -> None:
    events = (
        Event(0.05, "reshare", {"usable": [1, 2], "lost": [], "shares": {"1": [], "2": []}}),
        Event(1.0, "joined", {"shares": {"2": [1]}}),
        Event(2.0, "joined", {"shares": {"1": [2], "2": [3]}}),
        Event(300.0, "reshare", {"usable": [1], "lost": [2], "shares": {"1": [1, 2, 3]}}),
        Event(900.0, "joined", {"shares": {"1": [4]}}),
        Event(950.0, "joined", {"shares": {"1": "four"}}),  # damaged: no ids
        Event(990.0, "reshare", {"usable": [1, 2], "lost": [], "shares": {"1": 2, "2": 2}}),  # an older run's counts
    )
    first, second = reshares(events)
    assert (first.t_s, first.fields["shares"], first.fields["heard_until_s"]) == (0.05, {"1": [2], "2": [1, 3]}, 2.0)
    assert (second.t_s, second.fields["lost"], second.fields["shares"]) == (300.0, [2], {"1": [1, 2, 3, 4]})
    assert second.fields["heard_until_s"] == 900.0


def test_a_join_before_any_sharing_is_left_out() -> None:
    assert reshares((Event(1.0, "joined", {"shares": {"1": [5]}}),)) == []
