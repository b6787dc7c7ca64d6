""""Where the time went" over the time run (issue 20: a mission that ended at 9.5 h of a requested
24 h showed shares summing to 39 %, taken over the 24 h)."""

from __future__ import annotations

import io

from rich.console import Console

from gcs.cli.tables import time_table
from gcs.results.run_result import MusselResult, RunResult


def _row(text: str) -> list[str]:
    (line,) = [ln for ln in text.splitlines() if ln.strip().startswith("pool12 cautious s1")]
    return line.split()[3:]


def test_the_shares_are_of_the_time_run_when_the_mission_ended_early() -> None:
    hours = 3600.0
    # Asked for 24 h, ended at 9.5 h: each aMussel's seconds by state sum to the 9.5 h run.
    mussels = [MusselResult(i, 1.0, 50.0, state_s={"active": 5 * hours, "docked": 1.5 * hours, "depleted": 3 * hours})
               for i in (1, 2)]
    result = RunResult("pool12", "cautious", 1, 30.0, 24 * hours, {"avg": 50.0, "max": 50.0, "min": 50.0}, 0.0, 1.0,
                       1.0, mussels, end_reason="aPad battery")
    table = time_table([result])
    assert table is not None
    out = io.StringIO()
    Console(file=out, width=200).print(table)
    active, docked, depleted = (float(v) for v in _row(out.getvalue())[:3])
    assert (active, docked, depleted) == (52.6, 15.8, 31.6)  # of 9.5 h; over 24 h they would be 20.8, 6.2, 12.5
    assert active + docked + depleted == 100.0
