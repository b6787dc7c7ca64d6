"""The sleep order at the fleet's MAVLink edge, over real encoded bytes: taken, refused by reason, and a
sleeping aMussel's status heard only after its wakes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mavlink_dialect import Codec, mavlink
from missiontime import VirtualClock
from mussel_sim.behaviour import HOURLY_WAKE_AWAKE_S, HOURLY_WAKE_INTERVAL_S, duty_cycle_rate_per_min
from mussel_sim.comms import FLEET_COMPONENT_ID, FLEET_SYSTEM_ID, CommsConfig, FleetRunner
from mussel_sim.fleet_state import FleetParams, state_from_arrays
from mussel_sim.geo import LocalFrame
from mussel_sim.report_policy import LAST_WORDS
from mussel_sim.vocabulary import MusselState
from mussel_sim.wake import next_wake_s

FRAME = LocalFrame(43.9400, 15.4400)
APAD, GCS = 1, 255
gcs_codec = Codec(GCS, 190)
apad_codec = Codec(APAD, 1)


def _runner(params: FleetParams, ids: list[int]) -> tuple[FleetRunner, list[bytes]]:
    n = len(ids)
    state = state_from_arrays(ids, np.linspace(0, 30, n), np.zeros(n), [0.9] * n, params)
    sent: list[bytes] = []
    config = CommsConfig(apad_ids=frozenset({APAD}), commanders=frozenset({GCS}))
    return FleetRunner(state, params, np.random.default_rng(0), FRAME, Codec(FLEET_SYSTEM_ID, FLEET_COMPONENT_ID),
                       sent.append, config=config), sent


def order(mussel_id: int, interval: float, awake: float, codec: Codec = gcs_codec, target: int = APAD) -> bytes:
    return codec.encode(mavlink.MAVLink_amussel_sleep_order_message(target, mussel_id, interval, awake))


def test_an_order_over_the_wire_puts_an_amussel_on_its_schedule_and_duty_cycle_discharge() -> None:
    params = FleetParams(drift_half_width_m=0.0)
    runner, _ = _runner(params, [3, 5, 8])
    assert runner.feed(order(5, 1800.0, 30.0)) == 1
    runner.step_task(1_000_000)
    s = runner.state
    ordered = s.profiles.profiles[s.profile[1]]
    assert (ordered.name, ordered.wake_interval_s, ordered.awake_s) == ("always_on+order:1800s/30s", 1800.0, 30.0)
    assert ordered.discharge.rate_per_min == duty_cycle_rate_per_min(1800.0, 30.0)
    assert ordered.charge == s.profiles.profiles[s.profile[0]].charge  # the order is about the deployed behaviour
    drop = 0.9 - s.battery_frac
    assert drop[1] == pytest.approx(duty_cycle_rate_per_min(1800.0, 30.0) * 0.5, rel=1e-9)  # 30 s x theta 30
    assert drop[0] == drop[2] != drop[1]
    assert not runner.dropped


@pytest.mark.parametrize("frame, reason", [
    (order(5, -60.0, 10.0), "interval"),
    (order(5, math.nan, 10.0), "interval"),
    (order(5, math.inf, 10.0), "interval"),
    (order(5, 3600.0, math.nan), "awake"),
    (order(5, 3600.0, -1.0), "awake"),
    (order(5, 60.0, 120.0), "awake_over_interval"),
    (order(999, 3600.0, 10.0), "mussel_id"),
    (order(5, 3600.0, 10.0, target=9), "target"),
    (order(5, 3600.0, 10.0, codec=Codec(77, 190)), "source"),
])
def test_a_bad_order_is_dropped_and_counted_by_reason(frame: bytes, reason: str) -> None:
    runner, _ = _runner(FleetParams(drift_half_width_m=0.0), [3, 5, 8])
    runner.feed(frame)
    runner.step_task(1_000_000)
    assert dict(runner.dropped) == {f"invalid:AMUSSEL_SLEEP_ORDER:{reason}": 1}
    assert not runner.state.profile.any()  # nobody's profile changed


def test_a_sleeping_amussel_speaks_only_after_its_wakes_the_others_every_second() -> None:
    """Two sleeping aMussels and one always on ([fleet.profiles]), theta 30: a wake every 120 s."""
    params = FleetParams(drift_half_width_m=0.0, profile="hourly_wake", profile_ids=(("always_on", (8,)),))
    runner, sent = _runner(params, [3, 5, 8])
    clock = VirtualClock()
    runner.register(clock.scheduler)
    clock.sleep(400.0)
    heard: dict[int, list[float]] = {3: [], 5: [], 8: []}
    for m in (m for f in sent for m in gcs_codec.decode(f) if m.get_type() == "AMUSSEL_STATUS"):
        heard[m.mussel_id].append(m.time_us / 1e6)
    assert len(heard[8]) == 401  # always on: every publish, t = 0..400 s
    wakes = runner.recorder.samples()[1]
    assert wakes.tolist()[2] == 0 and (wakes[:2] >= 3).all()  # 400 s: three or four wakes each
    for k, i in enumerate((3, 5)):
        times = heard[i]
        assert times[0] == 0.0  # the first publish: everyone
        # then only in a second in which it was awake (a 10 s wake is 1/3 s here: one publish, or two
        # when it straddles one), at least once per wake
        for t in times[1:]:
            assert next_wake_s(i, HOURLY_WAKE_INTERVAL_S, HOURLY_WAKE_AWAKE_S, t - 1.0, params.theta) <= t, (i, t)
        assert wakes[k] <= len(times) - 1 <= 2 * wakes[k]
    assert (runner.state.state == MusselState.ACTIVE).all()


def test_the_order_sits_in_the_dialects_private_block_clear_of_upstream_dialects() -> None:
    import importlib

    msg_id = mavlink.MAVLINK_MSG_ID_AMUSSEL_SLEEP_ORDER
    assert 54000 <= msg_id <= 54099
    for upstream in ("ardupilotmega", "all"):
        assert msg_id not in importlib.import_module(f"pymavlink.dialects.v20.{upstream}").mavlink_map, upstream


def test_a_depleted_amussel_says_so_a_few_times_then_its_radio_is_off() -> None:
    """aMussel 5 depletes in its first step (eq. 1 at theta 30 takes 0.00052 a second); 3 and 8 do not."""
    params = FleetParams(drift_half_width_m=0.0)
    ids = [3, 5, 8]
    state = state_from_arrays(ids, [0.0, 10.0, 20.0], np.zeros(3), [0.9, 0.0005, 0.9], params)
    sent: list[bytes] = []
    runner = FleetRunner(state, params, np.random.default_rng(0), FRAME, Codec(FLEET_SYSTEM_ID, FLEET_COMPONENT_ID),
                         sent.append, config=CommsConfig(apad_ids=frozenset({APAD}), commanders=frozenset({GCS}),
                                                         sensors_rate_hz=1.0))
    clock = VirtualClock()
    runner.register(clock.scheduler)
    clock.sleep(60.0)
    heard: dict[tuple[str, int], list[float]] = {}
    for m in (m for f in sent for m in gcs_codec.decode(f)):
        if m.get_type() in ("AMUSSEL_STATUS", "AMUSSEL_SENSORS"):
            heard.setdefault((m.get_type(), m.mussel_id), []).append(m.time_us / 1e6)
    status_5 = [m for f in sent for m in gcs_codec.decode(f) if m.get_type() == "AMUSSEL_STATUS" and m.mussel_id == 5]
    # Published at 0 s (before its first step), then depleted from 1 s: that, LAST_WORDS times, then nothing.
    assert heard[("AMUSSEL_STATUS", 5)] == [float(t) for t in range(LAST_WORDS + 1)]
    assert [MusselState(m.state) for m in status_5[1:]] == [MusselState.DEPLETED] * LAST_WORDS
    assert heard[("AMUSSEL_SENSORS", 5)] == [float(t) for t in range(LAST_WORDS + 1)]
    for other in (3, 8):  # the living speak at every publish, 0..60 s
        assert len(heard[("AMUSSEL_STATUS", other)]) == len(heard[("AMUSSEL_SENSORS", other)]) == 61
