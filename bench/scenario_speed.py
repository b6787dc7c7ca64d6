"""Real-time factor of headless lockstep missions, and where the time goes.

For each scenario: one 40-minute mission in lockstep (SITL aPad, fleet and GCS on one virtual
clock, every message really encoded and parsed), timed without a profiler (best of --repeat),
then once under cProfile to split the time into disjoint parts: MAVLink encode, MAVLink parse,
fleet model step, planner, SITL physics, and everything else (scheduler, routing, handlers).
bay120 is a swarm (5 aPads, one loop each in its own thread, `missiontime.processes`): every thread
is profiled, and the time threads spend parked waiting for their turn is left out of the split.

    .venv/bin/python bench/scenario_speed.py [--repeat N] [--scenarios pool12 bay24 stress240 bay120]
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager

from rich.console import Console
from rich.table import Table

from gcs.mission.headless import run_mission
from gcs.mission.scenario import load_scenario

# label -> (file suffix, function name) entry points whose cumulative times do not overlap:
# one message at a time (codec.py) and the bulk messages' batch path (hot.py, hot_decode.py) together.
PARTS: dict[str, tuple[tuple[str, str], ...]] = {
    "MAVLink encode": (("mavlink_dialect/codec.py", "encode"), ("mavlink_dialect/hot.py", "encode_batch")),
    "MAVLink parse": (("mavlink_dialect/codec.py", "decode"), ("mavlink_dialect/hot_decode.py", "decode_datagrams")),
    "fleet step": (("mussel_sim/fleet.py", "step"),),
    "planner": (("gcs/mission/planner.py", "plan"),),
    "SITL physics": (("apad_sitl/endpoint.py", "_physics"),),
}


def timed(name: str, repeat: int) -> tuple[float, float, int]:
    """(best wall seconds, mission seconds, messages encoded) of one mission."""
    scenario = load_scenario(name)
    best = float("inf")
    for _ in range(repeat):
        start = time.perf_counter()
        result = run_mission(scenario)
        best = min(best, time.perf_counter() - start)
    messages = sum(result.messages.values())
    return best, scenario.mission.duration_s, messages


# Where a swarm's threads wait for their turn (missiontime.processes): idle, not work.
IDLE = ("~", 0, "<method 'acquire' of '_thread.lock' objects>")


@contextmanager
def threads_profiled(profilers: list[cProfile.Profile]) -> Iterator[None]:
    """Profile every thread started meanwhile (cProfile sees only the thread that enables it)."""
    original = threading.Thread.run

    def run(thread: threading.Thread) -> None:
        profilers.append(profiler := cProfile.Profile())
        profiler.runcall(original, thread)

    threading.Thread.run = run  # type: ignore[method-assign,assignment]
    try:
        yield
    finally:
        threading.Thread.run = original  # type: ignore[method-assign]


def profile_parts(name: str) -> dict[str, float]:
    """Fraction of profiled time (all threads, waits for a turn left out) per part, plus "other"."""
    scenario = load_scenario(name)
    profilers = [cProfile.Profile()]
    with threads_profiled(profilers):
        profilers[0].runcall(run_mission, scenario)
    merged = pstats.Stats(profilers[0])
    for profiler in profilers[1:]:
        merged.add(profiler)
    stats = merged.stats  # type: ignore[attr-defined]
    stats.pop(IDLE, None)
    total = sum(tt for (_, _, tt, _, _) in stats.values())  # (calls, prim calls, self, cumulative, callers)
    parts = {}
    for label, entries in PARTS.items():
        parts[label] = sum(ct for (file, _, fn), (_, _, _, ct, _) in stats.items()
                           if any(fn == func and file.endswith(suffix) for suffix, func in entries)) / total
    parts["other"] = max(0.0, 1.0 - sum(parts.values()))
    return parts


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=3, help="timed runs per scenario; the best counts (default 3)")
    parser.add_argument("--scenarios", nargs="+", default=["pool12", "bay24", "stress240", "bay120"])
    args = parser.parse_args()

    speed = Table(title="Lockstep missions: real-time factor (40 min of mission time each)")
    for col in ("scenario", "wall s", "real-time factor", "messages", "msg/s wall"):
        speed.add_column(col, justify="left" if col == "scenario" else "right")
    split = Table(title="Where the time goes (share of profiled time)")
    split.add_column("scenario")
    for label in [*PARTS, "other"]:
        split.add_column(label, justify="right")
    for name in args.scenarios:
        wall, mission, messages = timed(name, args.repeat)
        speed.add_row(name, f"{wall:.2f}", f"{mission / wall:,.0f}", f"{messages:,}", f"{messages / wall:,.0f}")
        parts = profile_parts(name)
        split.add_row(name, *(f"{parts[label]:.0%}" for label in [*PARTS, "other"]))
    console = Console(width=130)
    console.print(speed)
    console.print(split)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
