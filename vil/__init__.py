"""vil in Python: run, sweep and read missions from a notebook or a script.

    import vil
    r = vil.run("pool12", strategy="greedy", seed=1)      # the same mission as `vil run pool12 --strategy greedy`
    r.uptime_avg, r.cost_m                                # the paper's Table II figures
    r.mussels                                             # a pandas DataFrame: one row per aMussel
    r.active                                              # active aMussels over mission time
    vil.run("pool12", loss=0.2, latency="200ms", seed=3)  # every option `vil run` takes: faults, signing_key=,
                                                          #   fail_apads=, resume=True after a crash
    s = vil.scenario("pool12", fields={"mission.theta": 60, "fleet.count": 16})   # a variant, built in code
    frame = vil.sweep("missions/sweeps/quick.toml", out="sweeps/quick")           # one row per mission
    old = vil.load("runs/latest")                         # a recorded run, as `r` above

Strategies are named as everywhere else: a shipped name, "FILE.py:FUNCTION", "MODULE:FUNCTION" or
an installed `vil.strategies` entry point (docs/strategies.md). Errors are `vil.Error` with one line.
In a script, call `vil.sweep` under `if __name__ == "__main__":` (its workers import the script again).
"""

from __future__ import annotations

from vil.api import Error, load, run, scenario, sweep
from vil.result import Result

__all__ = ["Error", "Result", "load", "run", "scenario", "sweep"]
