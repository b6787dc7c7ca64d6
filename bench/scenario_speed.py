"""Real-time factor of headless lockstep missions, and where the time goes.

For each scenario: one 40-minute mission in lockstep (SITL aPad, fleet and GCS on one virtual
clock, every message really encoded and parsed), timed without instruments (best of --repeat,
wall seconds and, less sensitive to a busy machine, CPU seconds), then once more with the parts
timed: MAVLink encode, MAVLink parse, fleet model step, planner, SITL physics, and everything else
(scheduler, routing, handlers, the mission loop). Each part's time excludes the other parts it
calls (a physics step that announces a change counts its encoding as encode). bay120 is a swarm
(5 aPads, one loop each on a thread of `missiontime.processes`, one running at a time): the parts
are timed by wrapping their functions, which works across the threads' hand-overs (cProfile
profiles only the thread that started it). `bench/processes.py` times the hand-overs alone.

    .venv/bin/python bench/scenario_speed.py [--repeat N] [--scenarios pool12 bay24 stress240 bay120]
"""

from __future__ import annotations

import argparse
import importlib
import sys
import time
from collections import defaultdict
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

from rich.console import Console
from rich.table import Table

from gcs.mission.headless import run_mission
from gcs.scenario.reader import load_scenario

# label -> (module, attribute) of the functions timed as that part: the one-message codec and the
# bulk messages' batch path together, the fleet model, the planner, the aPad's physics task.
PARTS: dict[str, tuple[tuple[str, str], ...]] = {
    "MAVLink encode": (("mavlink_dialect.codec", "Codec.encode"), ("mavlink_dialect.hot", "encode_batch")),
    "MAVLink parse": (("mavlink_dialect.codec", "Codec.decode"), ("mavlink_dialect.hot_decode", "SharedDecode.decode"),
                      ("mavlink_dialect.hot_decode", "decode_datagrams")),
    "fleet step": (("mussel_sim.fleet", "step"),),
    "planner": (("gcs.strategies", "plan"),),
    "SITL physics": (("apad_sitl.parking", "PhysicsTicks.tick"), ("apad_sitl.parking", "PhysicsTicks.settle")),
}


def timed(name: str, repeat: int) -> tuple[float, float, float, int]:
    """(best wall seconds, best CPU seconds, mission seconds, messages encoded) of one mission."""
    scenario = load_scenario(name)
    best_wall = best_cpu = float("inf")
    for _ in range(repeat):
        wall, cpu = time.perf_counter(), time.process_time()
        result = run_mission(scenario)
        best_wall, best_cpu = min(best_wall, time.perf_counter() - wall), min(best_cpu, time.process_time() - cpu)
    messages = sum(v for k, v in result.messages.items() if k.endswith("_sent"))
    return best_wall, best_cpu, scenario.mission.duration_s, messages


class PartTimes:
    """Seconds spent in each part, the time of parts called inside another part left to them."""

    def __init__(self) -> None:
        self.seconds: defaultdict[str, float] = defaultdict(float)
        self._inner = [0.0]  # per open call: seconds of parts called inside it

    def wrap(self, label: str, fn: Callable[..., Any]) -> Callable[..., Any]:
        def part(*args: Any, **kwargs: Any) -> Any:
            self._inner.append(0.0)
            start = time.perf_counter()
            try:
                return fn(*args, **kwargs)
            finally:
                spent = time.perf_counter() - start
                self.seconds[label] += spent - self._inner.pop()
                self._inner[-1] += spent

        return part


@contextmanager
def parts_timed(times: PartTimes) -> Iterator[None]:
    """Every reference to a part's function (`from m import f` copies too) replaced by a timed one."""
    undo: list[tuple[Any, str, Any]] = []
    for label, entries in PARTS.items():
        for module_name, attr in entries:
            owner: Any = importlib.import_module(module_name)
            *path, name = attr.split(".")
            for step in path:
                owner = getattr(owner, step)
            original = getattr(owner, name)
            wrapped = times.wrap(label, original)
            holders = [owner] if path else [m for m in list(sys.modules.values()) if getattr(m, name, None) is original]
            for holder in holders:
                undo.append((holder, name, original))
                setattr(holder, name, wrapped)
    try:
        yield
    finally:
        for holder, name, original in reversed(undo):
            setattr(holder, name, original)


def split_parts(name: str) -> dict[str, float]:
    """Fraction of one mission's wall time per part, plus "other"."""
    scenario = load_scenario(name)
    times = PartTimes()
    with parts_timed(times):
        start = time.perf_counter()
        run_mission(scenario)
        total = time.perf_counter() - start
    parts = {label: times.seconds[label] / total for label in PARTS}
    parts["other"] = max(0.0, 1.0 - sum(parts.values()))
    return parts


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=3, help="timed runs per scenario; the best counts (default 3)")
    parser.add_argument("--scenarios", nargs="+", default=["pool12", "bay24", "stress240", "bay120"])
    args = parser.parse_args()

    speed = Table(title="Lockstep missions: real-time factor (40 min of mission time each)")
    for col in ("scenario", "wall s", "real-time factor", "CPU s", "RTF on CPU time", "messages", "msg/s wall"):
        speed.add_column(col, justify="left" if col == "scenario" else "right")
    split = Table(title="Where the time goes (share of one mission's wall time)")
    split.add_column("scenario")
    for label in [*PARTS, "other"]:
        split.add_column(label, justify="right")
    for name in args.scenarios:
        wall, cpu, mission, messages = timed(name, args.repeat)
        speed.add_row(name, f"{wall:.2f}", f"{mission / wall:,.0f}", f"{cpu:.2f}", f"{mission / cpu:,.0f}",
                      f"{messages:,}", f"{messages / wall:,.0f}")
        parts = split_parts(name)
        split.add_row(name, *(f"{parts[label]:.0%}" for label in [*PARTS, "other"]))
    console = Console(width=130)
    console.print(speed)
    console.print(split)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
