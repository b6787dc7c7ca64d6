"""Cost against mission time: does a day at sea cost what 36 forty-minute missions do, or less?

Issue 20's must-show, measured in one sitting: pool12 and bay120 as shipped, 40 min and 24 h of
mission time (the 24 h runs must not end early); and the sleeping fleet's day (bay120-sleep, 24 h)
against bay120's 40 minutes. Each run writes its output folder (in a temporary directory), so it
logs and checkpoints as `vil run` does. Prints wall and CPU seconds and the ratios against their
bounds (40x and 12x; linear in mission time would be 36x); asserts nothing. The 24 h runs take
minutes each: run it niced on a quiet machine, or pick runs with --only.

    .venv/bin/python bench/mission_cost.py [--only pool12 bay120 sleep] [--no-folder] [--day-h H]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from gcs.mission.headless import run_mission
from gcs.scenario.reader import load_scenario

DAY_S = 24 * 3600.0
SHORT_S = 40 * 60.0
# Issue 20's bounds: a day at most 40x its 40 minutes (linear is 36x); the sleeping day at most 12x
# bay120's 40 minutes.
DAY_BOUND = 40.0
SLEEP_BOUND = 12.0


@dataclass(frozen=True)
class Cost:
    name: str
    mission_s: float
    wall_s: float
    cpu_s: float
    end_reason: str
    uptime: dict[str, float]  # avg / min %: what the day did, to set beside the runs before a change

    @property
    def line(self) -> str:
        hours = self.mission_s / 3600.0
        return (f"  {self.name:13s} {hours:5.2f} h mission: {self.wall_s:8.2f} s wall, {self.cpu_s:8.2f} s CPU, "
                f"RTF {self.mission_s / self.wall_s:7,.0f}; ended on {self.end_reason!r}; "
                f"uptime {self.uptime['avg']:.2f} / {self.uptime['min']:.2f} %")


def cost(name: str, mission_s: float, folder: bool) -> Cost:
    """Wall and CPU seconds of one mission of `mission_s` (CPU covers every thread of the process)."""
    scenario = load_scenario(name).with_overrides(duration_s=mission_s)
    with tempfile.TemporaryDirectory(prefix="vil-cost-") as tmp:
        wall, cpu = time.perf_counter(), time.process_time()
        result = run_mission(scenario, Path(tmp) / "run" if folder else None)
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    return Cost(name, mission_s, wall, cpu, result.end_reason, dict(result.uptime))


def ratio(long: Cost, short: Cost, bound: float) -> str:
    verdict = "within" if long.wall_s <= bound * short.wall_s else "OVER"
    early = "" if long.end_reason == "mission time" else f"  (ended early: {long.end_reason})"
    return (f"  {long.name} {long.mission_s / 3600:g} h / {short.name} 40 min: "
            f"wall {long.wall_s / short.wall_s:6.1f}x, CPU {long.cpu_s / short.cpu_s:6.1f}x "
            f"({verdict} the bound {bound:g}x){early}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    runs = ["pool12", "bay120", "sleep"]
    parser.add_argument("--only", nargs="+", choices=runs, default=runs)
    parser.add_argument("--no-folder", action="store_true", help="no output folder (no logs, no checkpoints)")
    parser.add_argument("--day-h", type=float, default=DAY_S / 3600.0,
                        help="hours of the long missions (default 24: the bounds are for a day)")
    args = parser.parse_args()
    day_s = args.day_h * 3600.0
    folder = not args.no_folder
    lines: list[str] = []

    def measured(name: str, mission_s: float) -> Cost:
        c = cost(name, mission_s, folder)
        print(c.line, flush=True)
        return c

    print(f"Cost against mission time ({'logs and checkpoints as vil run' if folder else 'no output folder'})")
    bay120_short: Cost | None = None
    for name in ("pool12", "bay120"):
        if name in args.only or (name == "bay120" and "sleep" in args.only):
            short = measured(name, SHORT_S)
            if name == "bay120":
                bay120_short = short
            if name in args.only:
                lines.append(ratio(measured(name, day_s), short, DAY_BOUND))
    if "sleep" in args.only and bay120_short is not None:
        lines.append(ratio(measured("bay120-sleep", day_s), bay120_short, SLEEP_BOUND))
    print(f"Ratios (linear in mission time: {day_s / SHORT_S:g}x)")
    for line in lines:
        print(line)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
