"""When a telemetry stream of the SITL aPad sends next after SET_MESSAGE_INTERVAL (`streams.next_send_us`):
within one new interval always; sped up, on its old schedule's phase, so a GCS that slows a stream while
the aPad holds and speeds it up again sees the instants it would have seen had it never slowed it."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from apad_sitl.streams import next_send_us
from missiontime import Task

FAST_US, SLOW_US = 500_000, 5_000_000


def task(next_us: int, period_us: int, active: bool = True) -> Task:
    return Task("s", period_us, lambda now_us: None, next_us, 0, active)


@given(start_us=st.integers(0, 10**9), slow_at=st.integers(1, 2_000), fast_after_us=st.integers(1, 10**8))
def test_a_stream_slowed_and_sped_up_again_keeps_its_fast_phase(start_us: int, slow_at: int,
                                                                fast_after_us: int) -> None:
    # Fast from start_us; slowed at some instant between two sends; sped up again later.
    slow_now = start_us + slow_at * FAST_US - 1
    first_slow = next_send_us(task(start_us + slow_at * FAST_US, FAST_US), slow_now, SLOW_US)
    assert first_slow == start_us + slow_at * FAST_US  # already due within the new interval: unchanged
    fast_now = slow_now + fast_after_us
    # The slow schedule's first send after fast_now: first_slow + k x SLOW_US.
    slow_next = first_slow
    if fast_now >= first_slow:
        slow_next += SLOW_US * ((fast_now - first_slow) // SLOW_US + 1)
    sent = next_send_us(task(slow_next, SLOW_US), fast_now, FAST_US)
    assert fast_now < sent <= fast_now + FAST_US
    assert (sent - start_us) % FAST_US == 0  # on the fast schedule it had before it was slowed


def test_a_stream_switched_on_sends_within_one_interval() -> None:
    assert next_send_us(task(0, 1_000_000, active=False), 7_300_000, FAST_US) == 7_300_000
    assert next_send_us(task(9_000_000, 1_000_000), 7_300_000, FAST_US) == 7_500_000
