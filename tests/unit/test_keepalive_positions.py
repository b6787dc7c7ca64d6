"""The keep-alive's positions on the event platform (`mussel_sim.keepalive_positions`): what the GCS is handed
when it reads positions is where lockstep's keep-alive repeat at the window's start put each drifting aMussel,
draw for draw, whether the model is still before that start or stepped past it since; of the aMussels that
repeat would have carried, and only once a window."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from mussel_sim.fleet import step
from mussel_sim.fleet_state import NO_INPUTS, FleetParams, FleetState, state_from_arrays
from mussel_sim.geo import LocalFrame
from mussel_sim.keepalive_positions import KeepAlivePositions
from mussel_sim.vocabulary import MusselState

FRAME = LocalFrame(43.94, 15.44)
PARAMS = FleetParams(drift_half_width_m=0.05)
S = 1_000_000  # µs


def fleet(n: int = 6) -> FleetState:
    return state_from_arrays(list(range(3, 3 + n)), np.linspace(0, 30, n), np.zeros(n), [0.9] * n, PARAMS)


def lockstep_at(state: FleetState, seed: int, steps: int) -> FleetState:
    rng = np.random.default_rng(seed)
    for _ in range(steps):
        state = step(state, NO_INPUTS, PARAMS, rng, 1.0)[0]
    return state


def handed(keepalive: KeepAlivePositions) -> list[tuple[list[int], np.ndarray, np.ndarray]]:
    out: list[tuple[list[int], np.ndarray, np.ndarray]] = []
    keepalive.deliver = lambda ids, lat, lon: out.append((list(map(int, ids)), lat, lon))
    return out


def degrees_e7(state: FleetState) -> tuple[np.ndarray, np.ndarray]:
    lat, lon = FRAME.to_geodetic(state.x_m, state.y_m)
    return np.round(lat * 1e7).astype(np.int64), np.round(lon * 1e7).astype(np.int64)


def test_a_read_before_the_model_steps_gets_lockstep_s_positions_at_the_window_s_start() -> None:
    start = fleet()
    keepalive = KeepAlivePositions(start.n, 5 * S, S, FRAME, at_surface_only=False)
    got = handed(keepalive)
    keepalive.said(None, 0)  # everyone reported at the start
    rng = np.random.default_rng(11)
    keepalive.refresh(13 * S, start, rng, PARAMS)  # the window from 10 s: ten steps of drift on
    lat, lon = degrees_e7(lockstep_at(start, 11, 10))
    assert len(got) == 1 and got[0][0] == list(start.ids)
    np.testing.assert_array_equal(got[0][1], lat)
    np.testing.assert_array_equal(got[0][2], lon)
    keepalive.refresh(14 * S, start, rng, PARAMS)
    assert len(got) == 1  # once a window
    assert rng.bit_generator.state == np.random.default_rng(11).bit_generator.state  # the stream untouched


def test_a_step_across_the_window_s_start_keeps_the_positions_there_for_a_read_after_it() -> None:
    start = fleet()
    keepalive = KeepAlivePositions(start.n, 5 * S, S, FRAME, at_surface_only=False)
    got = handed(keepalive)
    keepalive.said(None, 0)
    rng = np.random.default_rng(11)
    keepalive.before_step(start, 17 * S, rng, PARAMS)  # a long step from 0 to 17 s crosses 15 s
    after = step(start, NO_INPUTS, PARAMS, rng, 17.0, 1.0)[0]
    np.testing.assert_allclose(after.x_m, lockstep_at(start, 11, 17).x_m, rtol=0.0, atol=1e-9)
    keepalive.refresh(18 * S, after, rng, PARAMS)
    lat, lon = degrees_e7(lockstep_at(start, 11, 15))
    np.testing.assert_array_equal(got[0][1], lat)
    np.testing.assert_array_equal(got[0][2], lon)


@pytest.mark.parametrize("why", ["docked", "depleted", "reported since"])
def test_only_what_the_repeat_would_have_carried(why: str) -> None:
    start = fleet()
    if why == "docked":  # a docked one is where its aPad is, which the GCS knows
        start = replace(start, state=np.array([MusselState.DOCKED] + [MusselState.ACTIVE] * (start.n - 1), np.uint8))
    elif why == "depleted":
        start = state_from_arrays(list(start.ids), start.x_m, start.y_m, [0.0] + [0.9] * (start.n - 1), PARAMS,
                                  state=[MusselState.DEPLETED] + [MusselState.ACTIVE] * (start.n - 1))
    keepalive = KeepAlivePositions(start.n, 5 * S, S, FRAME, at_surface_only=False)
    got = handed(keepalive)
    keepalive.said(None, 0)
    if why == "reported since":
        keepalive.said(np.array([0]), 12 * S)
    keepalive.refresh(13 * S, start, np.random.default_rng(1), PARAMS)
    assert got[0][0] == list(start.ids[1:])
