"""The acoustic sweep's table (docs/acoustic.md): every strategy with the channel off and on, side by side.

    python -m gcs.sweep.acoustic_compare sweeps/acoustic

Reads the sweep's cell files (DIR/cells/*.json; a sweep still running reports what it has), one row per
mission: scenario, strategy, seed, whether `[acoustic]` was enabled, uptime (mean and the worst
aMussel's), the aPad's movement cost, dockings, aMussels depleted, and with the channel on: how far
the believed battery was from the truth, how old the knowledge was, reports heard of sent and
call-ups never acknowledged. Two tables, per scenario and strategy over the seeds run both ways: the
mission's figures off and on (means, and the change in uptime), and what the channel did (on); the
lines below them name the strategy that holds up best on stale knowledge (the highest mean uptime
with the channel on, and the smallest loss against off).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import pandas as pd

from gcs.sweep.capacity import markdown
from gcs.sweep.store import read_cells


def mission_row(record: dict[str, Any]) -> dict[str, Any]:
    """One mission of the sweep, from its cell record."""
    result, values = record["result"], record["values"]
    a = result.get("acoustic") or {}
    k, counts, fleet = a.get("knowledge", {}), a.get("counts", {}), a.get("fleet", {})
    return {
        "scenario": record["scenario"], "strategy": record["strategy"], "seed": record["seed"],
        "acoustic": bool(values.get("acoustic.enabled", False)),
        "uptime_avg": result["uptime"]["avg"], "uptime_min": result["uptime"]["min"], "cost_m": result["cost_m"],
        "depleted": sum(1 for m in result["mussels"] if m["state_s"].get("depleted", 0.0) > 0.0),
        "dockings": sum(len(m["dockings"]) for m in result["mussels"]),
        "error_pct": 100.0 * k["battery_error_mean"] if k else None,
        "error_max_pct": 100.0 * k["battery_error_max"] if k else None,
        "age_median_s": k.get("age_median_s") if k else None,
        "age_max_s": k.get("age_max_s") if k else None,
        "heard_pct": 100.0 * counts.get("reports_heard", 0) / fleet["reports_sent"] if fleet.get("reports_sent")
        else None,
        "call_ups": counts.get("call_ups_acked", 0) + counts.get("call_ups_unacked", 0) if a else None,
        "call_ups_unacked": counts.get("call_ups_unacked", 0) if a else None,
        "call_up_retries": counts.get("call_up_retries", 0) if a else None,
    }


def read_missions(folder: Path) -> pd.DataFrame:
    rows = pd.DataFrame([mission_row(record) for record in read_cells(folder)])
    return rows.sort_values(["scenario", "strategy", "acoustic", "seed"], ignore_index=True)


def compare_table(rows: pd.DataFrame) -> pd.DataFrame:
    """Per scenario and strategy, the means over seeds with the channel off and on (only seeds run both ways)."""
    out = []
    for (scenario, strategy), group in rows.groupby(["scenario", "strategy"], sort=True):
        off, on = group[~group["acoustic"]].set_index("seed"), group[group["acoustic"]].set_index("seed")
        seeds = off.index.intersection(on.index)
        if not len(seeds):
            continue
        off, on = off.loc[seeds], on.loc[seeds]
        out.append({
            "scenario": scenario, "strategy": strategy, "seeds": len(seeds),
            "uptime off %": round(off["uptime_avg"].mean(), 2), "uptime on %": round(on["uptime_avg"].mean(), 2),
            "change": round(on["uptime_avg"].mean() - off["uptime_avg"].mean(), 2),
            "min uptime off %": round(off["uptime_min"].mean(), 1),
            "min uptime on %": round(on["uptime_min"].mean(), 1),
            "cost off m": round(off["cost_m"].mean(), 1), "cost on m": round(on["cost_m"].mean(), 1),
            "depleted off": round(off["depleted"].mean(), 2), "depleted on": round(on["depleted"].mean(), 2),
            "dockings off": round(off["dockings"].mean(), 1), "dockings on": round(on["dockings"].mean(), 1),
            "estimate error %": round(on["error_pct"].mean(), 3),
            "age median s": round(on["age_median_s"].mean(), 1), "age max s": round(on["age_max_s"].max(), 0),
            "reports heard %": round(on["heard_pct"].mean(), 2),
            "call-ups": int(on["call_ups"].sum()), "unacked": int(on["call_ups_unacked"].sum()),
            "retries": int(on["call_up_retries"].sum()),
        })
    return pd.DataFrame(out)


# The two tables printed: what the mission achieved off and on, and what the channel did (on).
OUTCOME = ("scenario", "strategy", "seeds", "uptime off %", "uptime on %", "change", "min uptime off %",
           "min uptime on %", "cost off m", "cost on m", "dockings off", "dockings on", "depleted off", "depleted on")
CHANNEL = ("scenario", "strategy", "estimate error %", "age median s", "age max s", "reports heard %", "call-ups",
           "unacked", "retries")


def verdicts(table: pd.DataFrame) -> list[str]:
    """Per scenario: the strategy with the highest uptime on stale knowledge, and the one whose uptime changes
    most for the better (or least for the worse) against the channel off."""
    lines = []
    for scenario, group in table.groupby("scenario", sort=True):
        best = group.loc[group["uptime on %"].idxmax()]
        steady = group.loc[group["change"].idxmax()]
        lines.append(f"{scenario}: best with the channel on: {best['strategy']} ({best['uptime on %']:.2f} % mean "
                     f"uptime, {best['change']:+.2f} against off); best change against off: {steady['strategy']} "
                     f"({steady['change']:+.2f})")
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m gcs.sweep.acoustic_compare", description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path, help="the acoustic sweep's folder (vil sweep ... --out DIR)")
    args = parser.parse_args(argv)
    try:
        rows = read_missions(args.folder)
    except (OSError, ValueError, KeyError) as exc:
        print(f"acoustic_compare: {exc}", file=sys.stderr)
        return 2
    table = compare_table(rows)
    if table.empty:
        print(f"acoustic_compare: {args.folder}: no seed was run both with the channel off and on", file=sys.stderr)
        return 2
    print(markdown(table[list(OUTCOME)]))
    print(markdown(table[list(CHANNEL)]))
    for line in verdicts(table):
        print(line)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
