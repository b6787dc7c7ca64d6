"""What a study reads of each mission: the outputs a sensitivity study explains and a tuning study optimises,
from a mission's result.json (`gcs.sweep.sensitivity`, `gcs.tune`, `gcs.sweep.capacity`)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

DAY_S = 86400.0  # a day of mission time: the "per day" figures' unit
OUTPUTS = ("uptime_min", "uptime_avg", "alive_at_end", "apad_wh_per_day", "samples_taken_pct", "dockings_per_day")
DEFAULT_OUTPUTS = ("uptime_min", "alive_at_end", "apad_wh_per_day")


def ran_flat(result: dict[str, Any]) -> int:
    """aMussels that ran flat (depleted) at any time of the mission."""
    return sum(1 for m in result.get("mussels", []) if m.get("state_s", {}).get("depleted", 0.0) > 0.0)


def output_values(result: dict[str, Any]) -> dict[str, float]:
    """Every output a study can explain (`sensitivity_design.OUTPUTS`), from one mission's result.json."""
    mussels = result.get("mussels") or []
    days = result.get("days") or []
    mission_days = max(float(result.get("duration_s", 0.0)) / DAY_S, 1e-9)
    apads = result.get("apads") or []
    taken = sum(m.get("samples_taken", 0) for m in mussels)
    scheduled = sum(m.get("samples_scheduled", 0) for m in mussels)
    alive = days[-1]["alive"] if days else len(mussels) - ran_flat(result)
    drawn = [a["drawn_wh"] for a in apads if a.get("drawn_wh") is not None]
    return {
        "uptime_min": float(result["uptime"]["min"]),
        "uptime_avg": float(result["uptime"]["avg"]),
        "alive_at_end": float(alive),
        "apad_wh_per_day": float(np.mean(drawn)) / mission_days if drawn else math.nan,
        "samples_taken_pct": 100.0 * taken / scheduled if scheduled else math.nan,
        "dockings_per_day": sum(len(m.get("dockings", [])) for m in mussels) / mission_days,
    }
