"""A run's figures per simulated day (the aMussels' day: 86,400 s / theta of mission time), for result.json
(`gcs.cli.tables.days_table` prints them).

Per day: the mission-time span it covers, the fleet's mean uptime (eq. 3 over the day's steps),
the aMussels alive (not DEPLETED) at the day's end and those that ran flat for the first time that
day, and per aPad the aMussels it charged (dockings that began that day) and the energy it passed
into them (Wh). A run of many days is summarised on the console in at most `MAX_ROWS` rows of equal
spans of days (the report and result.json keep every day).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from missiontime import US_PER_S
from mussel_sim.day_ledger import DayLedger

MAX_ROWS = 10  # console rows; more days are grouped
ENERGY_KEYS = ("passed_wh", "drawn_wh", "home_wh")  # each aPad's energy counters per day, Wh: the last axis


def day_rows(days: DayLedger, n_mussels: int, dockings: Mapping[int, Sequence[float]],
             energy: NDArray[np.float64], apad_ids: Sequence[int]) -> list[dict[str, Any]]:
    """One dict per day: day (1 = the first), from_s/to_s (mission seconds), uptime_pct, alive,
    depleted (first time that day), and per aPad (by system id, as text: JSON keys) charges and
    passed_wh. `dockings`: each aPad's docking times (mission s); `energy`: `(days, m, 3)` Wh per day."""
    uptime = days.uptime_pct(n_mussels)
    # A docking counts in the day as a step ending at its instant does (one rule: DayLedger.days_of).
    charges = {a: np.bincount(days.days_of(np.round(np.asarray(ts, np.float64) * US_PER_S).astype(np.int64)),
                              minlength=len(days.steps)) if len(ts) else np.zeros(len(days.steps), np.int64)
               for a, ts in dockings.items()}
    passed = ENERGY_KEYS.index("passed_wh")
    rows = []
    for d, (start_s, end_s) in enumerate(days.spans_s()):
        rows.append({
            "day": d + 1, "from_s": round(start_s, 3), "to_s": round(end_s, 3),
            "uptime_pct": round(float(uptime[d]), 4), "alive": days.alive_end[d], "depleted": days.depleted_new[d],
            "charges": {str(a): int(charges[a][d]) if a in charges and d < charges[a].size else 0 for a in apad_ids},
            "passed_wh": {str(a): round(float(energy[d, c, passed]), 3)
                          for c, a in enumerate(apad_ids) if d < energy.shape[0] and np.isfinite(energy[d, c, passed])},
        })
    return rows


def groups(n_days: int, max_rows: int = MAX_ROWS) -> list[range]:
    """Days 0..n-1 in at most `max_rows` consecutive spans of equal length (the last may be shorter)."""
    per = max(-(-n_days // max_rows), 1)
    return [range(k, min(k + per, n_days)) for k in range(0, n_days, per)]


