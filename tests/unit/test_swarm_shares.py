"""Owners and claims among aPads: never two aPads on one aMussel, and none left unservable."""

from __future__ import annotations

from gcs.swarm.partition import Partition
from gcs.swarm.shares import CLAIM_GRACE_S, FleetShares
from missiontime import seconds_to_us

A, B = 1, 2
M = 7  # an aMussel of A's share
BOTH = Partition({A: [M, 8], B: [9]}, {A: (0.0, 0.0), B: (50.0, 0.0)})
ONLY_B = Partition({B: [M, 8, 9]}, {B: (25.0, 0.0)})
GRACE_US = seconds_to_us(CLAIM_GRACE_S)


def test_an_apad_serves_and_claims_only_its_share_and_one_claim_excludes_the_other() -> None:
    shares = FleetShares()
    shares.reshare(frozenset({A, B}), BOTH, now_us=0)
    assert shares.serves(A, M, 0) and not shares.serves(B, M, 0)
    assert shares.claim(A, M, 0) and not shares.claim(B, M, 0)
    assert shares.holds(A, M)
    shares.release(A, M)
    assert not shares.holds(A, M) and shares.serves(A, M, 0)


def test_a_lost_apads_claim_holds_for_the_grace_then_the_aMussel_is_another_apads() -> None:
    shares = FleetShares()
    shares.reshare(frozenset({A, B}), BOTH, now_us=0)
    assert shares.claim(A, M, 0)  # A called M up ...
    t_lost = seconds_to_us(20.0)
    shares.reshare(frozenset({B}), ONLY_B, now_us=t_lost)  # ... and went silent
    assert shares.owner[M] == B
    assert shares.live_claim(M, t_lost + GRACE_US - 1) == A  # within the grace nobody takes it over
    assert not shares.claim(B, M, t_lost + GRACE_US - 1)
    after = t_lost + GRACE_US
    assert shares.live_claim(M, after) is None and shares.claim(B, M, after)  # an orphan B fetches
    # A comes back: its claim was taken over, so its loop leaves M alone (holds() is False).
    shares.reshare(frozenset({A, B}), BOTH, now_us=after + 1)
    assert not shares.holds(A, M) and shares.holds(B, M)
    assert shares.owner[M] == B  # a live claim keeps the aMussel with its claimant across re-shares


def test_an_apad_back_within_the_grace_keeps_its_claim() -> None:
    shares = FleetShares()
    shares.reshare(frozenset({A, B}), BOTH, now_us=0)
    assert shares.claim(A, M, 0)
    shares.reshare(frozenset({B}), ONLY_B, now_us=seconds_to_us(10.0))
    shares.reshare(frozenset({A, B}), BOTH, now_us=seconds_to_us(60.0))  # heard again before the grace ran out
    assert shares.holds(A, M) and shares.live_claim(M, seconds_to_us(10_000.0)) == A
    assert not shares.claim(B, M, seconds_to_us(10_000.0))
    assert shares.first is not None and shares.first.shares == BOTH.shares and shares.reshares == 3
