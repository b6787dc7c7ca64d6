"""A million hostile, valid-CRC MAVLink inputs into the GCS's and the SITL's receive paths.

    .venv/bin/python bench/fuzz_receive.py                 # 1,000,000 inputs, half to each side
    .venv/bin/python bench/fuzz_receive.py -n 20000 --seed 3

Every message of our dialect, fields hostile by type (tests/robust/hostile_packets.py), packed by a
real Codec, fed one at a time into a mission's world (the GCS link with the fleet as its local party,
the SITL aPad on an in-memory pair); mission time moves on every 50 inputs. Prints inputs/s, the
uncaught exceptions per message (must be 0), the catch-alls' handler errors (must be 0), what was
believed that cannot be (must be nothing) and the drop counts by reason. Exit status 1 on any of those.
This file is an edge: it may read clocks.
"""

from __future__ import annotations

import argparse
import sys
import time
import traceback
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "robust"))
from hostile_packets import FuzzWorld  # the generator the tests use

ADVANCE_EVERY = 50
ADVANCE_S = 0.3
TOP = 15


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-n", type=int, default=1_000_000, help="inputs in all, split over both sides")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args(argv)
    fuzz = FuzzWorld(args.seed)
    uncaught: Counter[str] = Counter()
    first: dict[str, str] = {}
    start = time.perf_counter()
    for i in range(args.n // 2):
        msg = fuzz.frames.message()
        frame = fuzz.frames.rng.choice(fuzz.frames.senders).encode(msg)
        for side in ("gcs", "sitl"):
            try:
                fuzz.feed(side, frame)
            except Exception:
                key = f"{side}:{msg.msgname}"
                uncaught[key] += 1
                first.setdefault(key, traceback.format_exc(limit=-3))
        if i % ADVANCE_EVERY == ADVANCE_EVERY - 1:
            try:
                fuzz.advance(ADVANCE_S)
            except Exception:
                uncaught["advance"] += 1
                first.setdefault("advance", traceback.format_exc(limit=-3))
    wall_s = time.perf_counter() - start
    inputs = sum(fuzz.fed.values())
    errors, impossible = fuzz.handler_errors(), fuzz.impossible()
    print(f"inputs: {inputs:,} (GCS {fuzz.fed['gcs']:,}, SITL {fuzz.fed['sitl']:,}), "
          f"{len(fuzz.frames.drawn)} message types, seed {args.seed}")
    print(f"wall time: {wall_s:.1f} s, {inputs / wall_s:,.0f} inputs/s")
    print(f"uncaught exceptions: {uncaught.total()}")
    for key, n in uncaught.most_common(TOP):
        print(f"  {n:7d} {key}\n{first[key]}")
    print(f"handler errors caught at a dispatch: {sum(errors.values())} {errors or ''}")
    print(f"believed though impossible: {len(impossible)} {impossible or ''}")
    for side, dropped in fuzz.drops().items():
        print(f"{side} dropped: {dropped.total():,} in {len(dropped)} reasons; top:")
        for reason, n in dropped.most_common(TOP):
            print(f"  {n:9,d} {reason}")
    fuzz.close()
    return 1 if uncaught or errors or impossible else 0


if __name__ == "__main__":
    sys.exit(main())
