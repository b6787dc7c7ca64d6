"""Random and mutated serial inputs through the nanomodem's command parser, the driver's reply parser
and the emulator (issue 21's hostile bytes).

    .venv/bin/python bench/fuzz_modem.py                   # 120,000 inputs: 60,000 random, 60,000 mutated
    .venv/bin/python bench/fuzz_modem.py -n 10000 --seed 3

Inputs come from tests/acoustic/serial_fuzz.py (the generator the tests use). Prints inputs/s, the
uncaught exceptions by type (must be 0; exit status 1 otherwise), and what each reader dropped, by
reason. This file is an edge: it may read clocks.
"""

from __future__ import annotations

import argparse
import sys
import time
import traceback
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "acoustic"))
from serial_fuzz import SerialFuzz  # the generator the tests use


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-n", type=int, default=120_000, help="inputs in all, half random, half mutated")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args(argv)
    fuzz = SerialFuzz(args.seed)
    uncaught: Counter[str] = Counter()
    first: dict[str, str] = {}
    n_bytes = 0
    start, cpu0 = time.perf_counter(), time.process_time()
    for i in range(args.n):
        data = fuzz.random_input() if i % 2 == 0 else fuzz.mutated_input()
        n_bytes += len(data)
        try:
            fuzz.feed(data)
        except Exception as exc:
            key = type(exc).__name__
            uncaught[key] += 1
            first.setdefault(key, traceback.format_exc(limit=-4))
    wall, cpu = time.perf_counter() - start, time.process_time() - cpu0
    print(f"{args.n:,} inputs ({n_bytes:,} bytes), half random, half mutated: {cpu:.1f} s CPU, "
          f"{args.n / wall:,.0f} inputs/s")
    print(f"uncaught exceptions: {sum(uncaught.values())}" + "".join(f"\n  {k}: {v}" for k, v in uncaught.items()))
    for text in first.values():
        print(text)
    emulator = fuzz.emulator
    for name, counts in (("command parser", fuzz.command_counts), ("reply parser (driver)", fuzz.replies.dropped),
                         ("emulator", emulator.counts), ("emulator's water", emulator.medium.counts)):
        print(f"{name}: " + ", ".join(f"{k} {v:,}" for k, v in sorted(counts.items(), key=lambda kv: -kv[1])))
    return 1 if uncaught else 0


if __name__ == "__main__":
    sys.exit(main())
