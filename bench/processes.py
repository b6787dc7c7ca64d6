"""The cost of a hand-over between `missiontime.processes` scripts, alone (no world to run).

Two or more scripts on one `VirtualClock` with nothing scheduled, each sleeping a period of its own
so that every sleep hands the baton to another script: wall microseconds per hand-over, and per
sleep of a script that is next again (no hand-over). A bay120 run of 40 minutes makes about 24,000
hand-overs. `--module FILE` times another implementation of the module (an older copy, say).

    .venv/bin/python bench/processes.py [--scripts 5] [--sleeps 20000] [--repeat 5] [--module FILE]
"""

from __future__ import annotations

import argparse
import importlib.util
import sys
import time
from types import ModuleType

from missiontime import Clock, VirtualClock


def load(path: str | None) -> ModuleType:
    if path is None:
        return importlib.import_module("missiontime.processes")
    spec = importlib.util.spec_from_file_location("processes_under_test", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


def per_sleep_us(module: ModuleType, scripts: int, sleeps: int, alone: bool) -> float:
    """Wall microseconds per `sleep`: `scripts` taking turns (each sleep a hand-over), or, `alone`,
    one busy script and idle others (sleeps without a hand-over)."""
    clock = VirtualClock()
    each = sleeps // scripts if not alone else sleeps

    def script(period_s: float, n: int) -> object:
        def body(c: Clock) -> None:
            for _ in range(n):
                c.sleep(period_s)

        return body

    procs = module.Processes(clock)
    if alone:
        procs.spawn("busy", script(0.001, each))
        for k in range(scripts - 1):
            procs.spawn(f"idle{k}", script(3600.0, 1))
    else:
        for k in range(scripts):
            procs.spawn(f"s{k}", script(1.0, each))  # same period: round robin, every sleep hands over
    start = time.perf_counter()
    procs.run()
    return (time.perf_counter() - start) / each / (1 if alone else scripts) * 1e6


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scripts", type=int, default=5)
    parser.add_argument("--sleeps", type=int, default=20000)
    parser.add_argument("--repeat", type=int, default=5, help="the best of this many runs counts")
    parser.add_argument("--module", help="a file implementing missiontime.processes' API to time instead")
    args = parser.parse_args()
    module = load(args.module)
    for alone, label in ((False, "hand-over"), (True, "sleep, next again")):
        best = min(per_sleep_us(module, args.scripts, args.sleeps, alone) for _ in range(args.repeat))
        print(f"{label:>18}: {best:6.2f} us ({args.scripts} scripts, {module.__file__})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
