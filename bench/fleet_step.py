"""Time one 1 Hz step of the aMussel fleet model: vectorised numpy vs a plain per-agent Python loop.

    .venv/bin/python bench/fleet_step.py

The loop below is the reference: the same model (eqs. (1)-(2), timers, depletion, docked-follow,
the paper's random drift) written the way an object-per-agent simulator would. Before timing, both
are run side by side without drift to show they compute the same batteries and states.
Target: 10,000 aMussels in under 1 ms per step. This file is an edge: it may read clocks.
"""

from __future__ import annotations

import random
import statistics
import time
from dataclasses import dataclass

import numpy as np
from rich.console import Console
from rich.table import Table

from mussel_sim.fleet import step
from mussel_sim.fleet_state import FleetInputs, FleetParams, FleetState, state_from_arrays
from mussel_sim.vocabulary import MusselState

SIZES = (12, 1_000, 10_000, 100_000)
LOOP_SUBSET = 10_000  # above this the loop is timed on a subset and scaled linearly
TARGET_N, TARGET_US = 10_000, 1_000.0
APAD_ID, APAD_XY = 1, (25.0, 25.0)

A, SU, FL, DO, SI, DE = (int(s) for s in MusselState)


# --- the reference: one Python object per aMussel ---------------------------------------------------


@dataclass
class PyMussel:
    x_m: float
    y_m: float
    u: float
    state: int
    timer_s: float = 0.0
    dock_apad: int = 0


def loop_step(mussels: list[PyMussel], apads: dict[int, tuple[float, float]], p: FleetParams,
              rnd: random.Random, dt_s: float) -> None:
    dt_min = p.theta * (dt_s / 60.0)
    dis = p.discharge.rate_per_min * dt_min
    th, rates = p.charge.thresholds, p.charge.rates_per_min
    h = p.drift_half_width_m
    for m in mussels:
        if m.state in (SU, SI):
            m.timer_s -= dt_s
            if m.timer_s <= 1e-9:
                m.timer_s = 0.0
                m.state = FL if m.state == SU else A
        if m.state == DO:
            band = 0
            while band < len(th) and m.u > th[band]:
                band += 1
            m.u = min(1.0, m.u + rates[band] * dt_min)
            if m.dock_apad in apads:
                m.x_m, m.y_m = apads[m.dock_apad]
        else:
            m.u = max(0.0, m.u - dis)
            if m.u <= 0.0 and m.state != DE:
                m.state = DE
                m.timer_s = 0.0
            if h > 0:
                m.x_m += rnd.uniform(-h, h)
                m.y_m += rnd.uniform(-h, h)


def to_objects(s: FleetState) -> list[PyMussel]:
    return [
        PyMussel(float(x), float(y), float(u), int(st), float(t), int(a))
        for x, y, u, st, t, a in zip(s.x_m, s.y_m, s.battery_frac, s.state, s.timer_s, s.dock_apad, strict=True)
    ]


# --- set-up and timing -----------------------------------------------------------------------------


def make_fleet(n: int, p: FleetParams, seed: int = 1) -> FleetState:
    """n aMussels in a 50 m square, 4 docked on the aPad, a few surfacing/sinking."""
    rng = np.random.default_rng(seed)
    ids = np.arange(1, n + 1)
    s = state_from_arrays(ids, rng.uniform(0, 50, n), rng.uniform(0, 50, n), rng.uniform(0.6, 1.0, n), p)
    k = min(4, n)
    inputs = FleetInputs.make(
        apads={APAD_ID: APAD_XY},
        dock=[(int(i), APAD_ID, slot + 1) for slot, i in enumerate(ids[:k])],
        surface=ids[k : k + max(n // 100, 1)].tolist(),
    )
    s, _ = step(s, inputs, p, rng, 1.0)
    return s


def time_vectorised(s: FleetState, p: FleetParams, reps: int) -> float:
    """Median microseconds per step over `reps` steps."""
    rng = np.random.default_rng(2)
    inputs = FleetInputs.make(apads={APAD_ID: APAD_XY})
    times = []
    for _ in range(reps):
        t0 = time.perf_counter()
        s, _ = step(s, inputs, p, rng, 1.0)
        times.append(time.perf_counter() - t0)
    return statistics.median(times) * 1e6


def time_loop(s: FleetState, p: FleetParams, reps: int) -> float:
    mussels = to_objects(s)
    rnd = random.Random(2)
    apads = {APAD_ID: APAD_XY}
    times = []
    for _ in range(reps):
        t0 = time.perf_counter()
        loop_step(mussels, apads, p, rnd, 1.0)
        times.append(time.perf_counter() - t0)
    return statistics.median(times) * 1e6


def check_same_model(p: FleetParams, n: int = 500, steps: int = 300) -> float:
    """Largest battery difference between the two implementations (drift off); states must match."""
    q = FleetParams(theta=p.theta, drift_half_width_m=0.0)
    s = make_fleet(n, q)
    mussels = to_objects(s)
    rng = np.random.default_rng(0)
    rnd = random.Random(0)
    inputs = FleetInputs.make(apads={APAD_ID: APAD_XY})
    for _ in range(steps):
        s, _ = step(s, inputs, q, rng, 1.0)
        loop_step(mussels, {APAD_ID: APAD_XY}, q, rnd, 1.0)
    if [m.state for m in mussels] != s.state.tolist():
        raise SystemExit("reference loop and vectorised model disagree on states")
    return float(np.max(np.abs(np.array([m.u for m in mussels]) - s.battery_frac)))


def main() -> None:
    console = Console(width=120)
    p = FleetParams()
    diff = check_same_model(p)
    console.print(f"reference loop vs vectorised, 500 aMussels x 300 steps: max |du| = {diff:.1e}, states equal")

    table = Table(title="aMussel fleet: one 1 Hz step (theta = 30, paper drift, 4 docked)")
    for col in ("aMussels", "numpy (us/step)", "per-agent loop (us/step)", "speed-up", "note"):
        table.add_column(col, justify="right" if col != "note" else "left")
    results = {}
    for n in SIZES:
        s = make_fleet(n, p)
        reps = 2000 if n <= 1000 else (400 if n <= 10_000 else 60)
        vec_us = time_vectorised(s, p, reps)
        if n <= LOOP_SUBSET:
            loop_us = time_loop(s, p, 200 if n <= 1000 else 15)
            note = ""
        else:
            sub = make_fleet(LOOP_SUBSET, p)
            loop_us = time_loop(sub, p, 15) * n / LOOP_SUBSET
            note = f"loop timed on {LOOP_SUBSET:,}, scaled x{n // LOOP_SUBSET}"
        results[n] = vec_us
        table.add_row(f"{n:,}", f"{vec_us:,.1f}", f"{loop_us:,.1f}", f"{loop_us / vec_us:,.1f}x", note)
    console.print(table)
    ok = results[TARGET_N] < TARGET_US
    console.print(
        f"target: {TARGET_N:,} aMussels under {TARGET_US:,.0f} us per step -> "
        f"{results[TARGET_N]:,.1f} us [{'bold green' if ok else 'bold red'}]{'met' if ok else 'MISSED'}[/]"
    )


if __name__ == "__main__":
    main()
