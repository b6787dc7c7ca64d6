"""Whole missions over a bad link: does every run complete, is anything lost, what does it cost?

Each run is pool12 (40 min) in lockstep with the aPad on real UDP through the seeded fault proxy,
the same as `vil run pool12 --loss L --latency S --duplicate D --seed N`. Issue 10's goal: at 40 %
loss, 200 ms latency and 5 % duplicates, seeds 1-10 all complete with nothing lost, each in under
60 s of wall time. Prints one row per seed and the totals; exits 1 if a run lost an aMussel.

    .venv/bin/python bench/lossy_runs.py [--seeds 10] [--loss 0.4] [--latency 0.2] [--duplicate 0.05]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

from rich.console import Console
from rich.table import Table

from gcs.link.faultproxy import LinkFaults
from gcs.mission.headless import run_mission
from gcs.mission.world import LinkOptions
from gcs.scenario.reader import load_scenario

COUNTED = ("failsafe",)  # aPad events
GCS_COUNTED = ("goto_resumed", "goto_unconfirmed", "goto_timeout", "command_failed", "gave_up", "link_lost")


def _count(path: Path, kinds: tuple[str, ...]) -> Counter[str]:
    events = (json.loads(line)["event"] for line in path.read_text().splitlines())
    return Counter(e for e in events if e in kinds)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenario", default="pool12")
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--loss", type=float, default=0.4)
    ap.add_argument("--latency", type=float, default=0.2)
    ap.add_argument("--duplicate", type=float, default=0.05)
    args = ap.parse_args()
    table = Table(title=f"{args.scenario}: {args.loss:.0%} loss, {args.latency * 1000:.0f} ms, "
                        f"{args.duplicate:.0%} duplicates, both ways")
    for name in ("seed", "wall s", "RTF", "end", "avg %", "min %", "cost m", "cycles", "misplaced", "failsafe",
                 "resumed", "unconf.", "timeout", "cmd fail", "gave up", "link lost"):
        table.add_column(name, justify="right")
    walls, misplaced_runs = [], 0
    for seed in range(1, args.seeds + 1):
        scenario = load_scenario(args.scenario).with_overrides(seed=seed)
        # As `vil run --seed N` does: the proxy's draws are seeded with the run's seed too.
        faults = LinkFaults(loss_frac=args.loss, latency_s=args.latency, duplicate_frac=args.duplicate, seed=seed)
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp)
            start = time.perf_counter()
            r = run_mission(scenario, out, options=LinkOptions(faults=faults))
            wall = time.perf_counter() - start
            apad, gcs = _count(out / "apad1.events.jsonl", COUNTED), _count(out / "events.jsonl", GCS_COUNTED)
        walls.append(wall)
        misplaced_runs += bool(r.misplaced)
        table.add_row(str(seed), f"{wall:.1f}", f"{r.duration_s / wall:.0f}", r.end_reason, f"{r.uptime['avg']:.1f}",
                      f"{r.uptime['min']:.1f}", f"{r.cost_m:.0f}", str(r.cycles), str(len(r.misplaced)),
                      str(apad["failsafe"]), *(str(gcs[k]) for k in GCS_COUNTED))
    console = Console(width=160)
    console.print(table)
    console.print(f"{args.seeds} runs: wall {min(walls):.1f}-{max(walls):.1f} s (mean {sum(walls) / len(walls):.1f});"
                  f" runs with an aMussel not where it should be: {misplaced_runs}")
    return 1 if misplaced_runs else 0


if __name__ == "__main__":
    sys.exit(main())
