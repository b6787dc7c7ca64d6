""""Where the time went" over the time run (issue 20: a mission that ended at 9.5 h of a requested
24 h showed shares summing to 39 %, taken over the 24 h)."""

from __future__ import annotations

import io
from dataclasses import replace

from rich.console import Console

from gcs.cli.tables import happened_lines, time_table
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


def test_what_happened_says_when_the_fleet_ran_flat_and_how_long_the_apad_charged_at_home() -> None:
    mussels = [MusselResult(1, 1.0, 50.0, first_depleted_s=1381.0), MusselResult(2, 1.0, 40.0, first_depleted_s=9401.0)]
    apads = [{"sysid": 1, "home_charges": 1, "phase_s": {"home charge": 9843.0}}, {"sysid": 2, "home_charges": 0}]
    result = RunResult("pool12", "greedy", 1, 30.0, 6 * 3600.0, {"avg": 45.0, "max": 50.0, "min": 40.0}, 0.0, 1.0,
                       1.0, mussels, apads=apads)
    assert happened_lines([result]) == [
        "pool12 greedy s1: aPad 1 charged at home x1 (2:44:03 at the charger); "
        "every aMussel ran flat (the first at 23:01, the last at 2:36:41)"]
    some = replace(result, mussels=[*mussels[:1], MusselResult(3, 1.0, 90.0)], apads=[])
    assert happened_lines([some]) == ["pool12 greedy s1: 1 of 2 aMussels ran flat (at 23:01)"]
    assert happened_lines([replace(some, mussels=[MusselResult(3, 1.0, 90.0)])]) == []
