"""Does a long mission cost in proportion to its length? pool12 for 40 min and for 4 h of mission time.

Both runs write their output folder (in a temporary directory), so they checkpoint every
`CHECKPOINT_PERIOD_S` of mission time, as `vil run` does. A checkpoint whose cost grows with the
mission makes the 4 h run cost far more than 6x the 40 min one; so does the mean cost of a save in
the last quarter of the long run against its first quarter. Prints figures, asserts nothing.

    .venv/bin/python bench/long_mission.py [--scenario pool12] [--short 40] [--long 240] [--repeat 1]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from gcs.mission import checkpoint
from gcs.mission.headless import run_mission
from gcs.scenario.reader import load_scenario


def wall_s(name: str, minutes: float, repeat: int) -> tuple[float, list[float]]:
    """Best wall seconds of `repeat` missions of `minutes` of mission time, with checkpoints on,
    and the wall seconds of each checkpoint save of that best run."""
    scenario = load_scenario(name).with_overrides(duration_s=minutes * 60.0)
    best, best_saves = float("inf"), []
    real_save = checkpoint.save
    for _ in range(repeat):
        saves: list[float] = []

        def timed_save(*args: object, saves: list[float] = saves) -> None:
            t = time.perf_counter()
            real_save(*args)  # type: ignore[arg-type]
            saves.append(time.perf_counter() - t)

        checkpoint.save = timed_save  # type: ignore[assignment]  # headless calls it as checkpoint.save
        try:
            with tempfile.TemporaryDirectory(prefix="vil-long-") as tmp:
                start = time.perf_counter()
                run_mission(scenario, Path(tmp) / "run")
                wall = time.perf_counter() - start
        finally:
            checkpoint.save = real_save
        if wall < best:
            best, best_saves = wall, saves
    return best, best_saves


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenario", default="pool12")
    parser.add_argument("--short", type=float, default=40.0, help="minutes of mission time (default 40)")
    parser.add_argument("--long", type=float, default=240.0, help="minutes of mission time (default 240)")
    parser.add_argument("--repeat", type=int, default=1, help="runs of each; the best counts (default 1)")
    args = parser.parse_args()
    short, short_saves = wall_s(args.scenario, args.short, args.repeat)
    long, long_saves = wall_s(args.scenario, args.long, args.repeat)
    print(f"{args.scenario}, checkpoints on, best of {args.repeat}")
    for minutes, wall, saves in ((args.short, short, short_saves), (args.long, long, long_saves)):
        print(f"  {minutes:6.0f} min mission: {wall:8.2f} s wall, real-time factor {minutes * 60 / wall:8,.0f}, "
              f"{len(saves)} checkpoints, {sum(saves) / wall:5.1%} of wall in them")
    print(f"  cost ratio long/short: {long / short:.2f} (mission length ratio {args.long / args.short:.2f})")
    q = len(long_saves) // 4
    if q:
        first, last = sum(long_saves[:q]) / q, sum(long_saves[-q:]) / q
        print(f"  long run, mean ms per checkpoint: first quarter {first * 1e3:.2f}, last quarter {last * 1e3:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
