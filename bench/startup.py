"""Start-up cost of the command line: `vil --help`, and importing the MAVLink dialect.

Each is run as a fresh process (best of --repeat): wall seconds and peak memory. With
PYTHONDONTWRITEBYTECODE set and no compiled bytecode, the 25,000-line generated dialect is
compiled at every start; `make` compiles it once at set-up (compileall), so this shows both.

    .venv/bin/python bench/startup.py [--repeat 5]
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import time

from rich.console import Console
from rich.table import Table

CASES = (
    ("vil --help", [sys.executable, "-m", "gcs.cli", "--help"]),
    ("vil run --help", [sys.executable, "-m", "gcs.cli", "run", "--help"]),
    ("import mavlink_dialect", [sys.executable, "-c", "import mavlink_dialect"]),
)


def measure(cmd: list[str], repeat: int) -> tuple[float, float]:
    """(best wall seconds, peak RSS MiB of the children so far)."""
    best = float("inf")
    env = {**os.environ, "PYTHONDONTWRITEBYTECODE": "1"}
    for _ in range(repeat):
        start = time.perf_counter()
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, env=env)
        best = min(best, time.perf_counter() - start)
    return best, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    table = Table(title=f"Start-up (fresh process, PYTHONDONTWRITEBYTECODE=1, best of {args.repeat})")
    for col in ("command", "wall s", "peak RSS MiB (max so far)"):
        table.add_column(col, justify="left" if col == "command" else "right")
    for name, cmd in CASES:
        wall_s, rss_mib = measure(cmd, args.repeat)
        table.add_row(name, f"{wall_s:.3f}", f"{rss_mib:.0f}")
    Console().print(table)


if __name__ == "__main__":
    main()
