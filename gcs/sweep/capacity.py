"""The capacity study's table and figure (docs/capacity.md): how many aMussels one aPad keeps alive.

    python -m gcs.sweep.capacity sweeps/capacity --figure docs/capacity.png

Reads the sweep's cell files (DIR/cells/*.json: a sweep still running, or resumed, reports what it has),
one row per mission: its profile and fleet size, strategy and seed; whether it kept every aMussel alive (none
depleted at any time, and the mission ran its whole duration: one ended early by the aPad's battery kept no
one), how many depleted, uptime, samples taken against scheduled, the aPad's dockings (one charge each),
rounds and energy passed into aMussels per day of mission time, and its hours home at the charger. The table
gives, per profile and strategy, the largest fleet kept alive in at least KEPT_SHARE of its seeds, and at that
size what the aPad did for it, with the spread over the seeds.
"""

from __future__ import annotations

import argparse
import io
import sys
from pathlib import Path
from typing import Any

import pandas as pd

from gcs.sweep.outputs import DAY_S, ran_flat
from gcs.sweep.store import read_cells

KEPT_SHARE = 0.9  # "kept alive": no aMussel depleted in at least 9 of 10 seeds


def mission_row(record: dict[str, Any]) -> dict[str, Any]:
    """One mission of the sweep, from its cell record."""
    result, values = record["result"], record["values"]
    mussels = result["mussels"]
    days = result["duration_s"] / DAY_S
    apads = result.get("apads") or [{}]
    dockings = sum(len(m["dockings"]) for m in mussels)
    return {
        "profile": values.get("fleet.profile", "always_on"),
        "count": int(values.get("fleet.count", len(mussels))),
        "strategy": record["strategy"],
        "seed": record["seed"],
        "alive": result["end_reason"] == "mission time"
                 and all(m["state_s"].get("depleted", 0.0) == 0.0 for m in mussels),
        "depleted": ran_flat(result),
        "uptime_avg": result["uptime"]["avg"],
        "uptime_min": result["uptime"]["min"],
        "samples_taken": sum(m.get("samples_taken", 0) for m in mussels),
        "samples_scheduled": sum(m.get("samples_scheduled", 0) for m in mussels),
        "dockings_per_day": dockings / days,
        "rounds_per_day": result["cycles"] / days,
        "passed_wh_per_day": sum(a.get("passed_wh") or 0.0 for a in apads) / len(apads) / days,
        "home_h": round(sum(a.get("phase_s", {}).get("home charge", 0.0) for a in apads) / 3600.0, 2),  # charging
        "days": days,
        "sim_days": days * result["theta"],  # the aMussels' days (theta 30: a mission day is 30)
        "end": result["end_reason"],
    }


def read_missions(folder: Path) -> pd.DataFrame:
    """Every finished mission in `folder`/cells, sorted by profile, strategy, count and seed."""
    rows = pd.DataFrame([mission_row(record) for record in read_cells(folder)])
    return rows.sort_values(["profile", "strategy", "count", "seed"], ignore_index=True)


def capacity_table(rows: pd.DataFrame) -> pd.DataFrame:
    """Per profile and strategy: the largest fleet swept that at least KEPT_SHARE of its seeds kept alive ("< N":
    not even the smallest, N), the seeds that did at that size, the sizes swept, and at that size (else the
    smallest) the aPad's dockings (charging cycles), rounds and energy passed per day, uptime and samples taken
    of scheduled, each a mean over the seeds (uptime: with its standard deviation)."""
    out = []
    for (profile, strategy), group in rows.groupby(["profile", "strategy"], sort=True):
        by_count = group.groupby("count").agg(
            alive=("alive", "mean"), kept=("alive", "sum"), depleted=("depleted", "mean"),
            uptime_avg=("uptime_avg", "mean"), uptime_avg_sd=("uptime_avg", "std"),
            uptime_min=("uptime_min", "mean"), uptime_min_sd=("uptime_min", "std"),
            dockings_per_day=("dockings_per_day", "mean"), rounds_per_day=("rounds_per_day", "mean"),
            passed_wh_per_day=("passed_wh_per_day", "mean"), home_h=("home_h", "mean"),
            taken=("samples_taken", "sum"), scheduled=("samples_scheduled", "sum"), seeds=("seed", "nunique"))
        kept = by_count.index[by_count["alive"] >= KEPT_SHARE - 1e-9]
        at = int(kept.max()) if len(kept) else int(by_count.index.min())
        r = by_count.loc[at]
        out.append({
            "profile": profile, "strategy": strategy,
            "largest kept alive": str(at) if len(kept) else f"< {at}",
            "seeds kept": f"{int(r['kept'])}/{int(r['seeds'])}",
            "sizes swept": " ".join(str(int(c)) for c in by_count.index),
            "dockings / day": round(float(r["dockings_per_day"]), 1),
            "rounds / day": round(float(r["rounds_per_day"]), 1),
            "Wh passed / day": round(float(r["passed_wh_per_day"]), 1),
            "hours home": round(float(r["home_h"]), 1),
            "uptime avg %": _mean_sd(r["uptime_avg"], r["uptime_avg_sd"]),
            "uptime min %": _mean_sd(r["uptime_min"], r["uptime_min_sd"]),
            "samples taken %": round(100.0 * float(r["taken"]) / float(r["scheduled"]), 1) if r["scheduled"] else None,
        })
    return pd.DataFrame(out)


def _mean_sd(mean: float, sd: float) -> str:
    return f"{mean:.1f}" if pd.isna(sd) else f"{mean:.1f} ± {sd:.1f}"


def figure(rows: pd.DataFrame, path: Path) -> None:
    """Per profile (columns), against the fleet's size, a line per strategy (the mean over seeds, the band its
    spread: min to max for aMussels depleted, one standard deviation for the others): aMussels depleted,
    minimum uptime, samples taken of scheduled, and the aPad's dockings per day."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    profiles = sorted(rows["profile"].unique())
    panels = (("depleted", "aMussels depleted"), ("uptime_min", "minimum uptime %"),
              ("samples_pct", "samples taken of scheduled %"), ("dockings_per_day", "dockings (charges) per day"))
    rows = rows.assign(samples_pct=100.0 * rows["samples_taken"] / rows["samples_scheduled"].where(
        rows["samples_scheduled"] > 0))
    fig, axes = plt.subplots(len(panels), len(profiles), figsize=(5.4 * len(profiles), 2.6 * len(panels)),
                             squeeze=False, sharex="col")
    colour = {strategy: f"C{k}" for k, strategy in enumerate(sorted(rows["strategy"].unique()))}  # one per panel
    for col, profile in enumerate(profiles):
        mine = rows[rows["profile"] == profile]
        for strategy, group in mine.groupby("strategy", sort=True):
            for row, (key, _) in enumerate(panels):
                stats = group.groupby("count")[key].agg(["mean", "std", "min", "max"])
                if stats["mean"].isna().all():
                    continue
                ax = axes[row][col]
                line = ax.plot(stats.index, stats["mean"], marker="o", markersize=3, label=strategy,
                               color=colour[strategy])[0]
                low, high = ((stats["min"], stats["max"]) if key == "depleted"
                             else (stats["mean"] - stats["std"].fillna(0), stats["mean"] + stats["std"].fillna(0)))
                ax.fill_between(stats.index, low, high, color=line.get_color(), alpha=0.15, linewidth=0)
        counts = sorted(mine["count"].unique())
        axes[0][col].plot(counts, counts, color="0.7", linestyle=":", label="the whole fleet")
        hours, sim_days = 24 * float(mine["days"].max()), float(mine["sim_days"].max())
        seeds = int(mine["seed"].nunique())
        axes[0][col].set_title(f"{profile}: one aPad, {hours:g} h ({sim_days:g} sim. days), {seeds} seeds")
        for row, (_, label) in enumerate(panels):
            axes[row][col].set_ylabel(label)
        axes[-1][col].set_xticks(counts)
        axes[-1][col].set_xlabel("aMussels in the fleet")
        axes[0][col].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def markdown(table: pd.DataFrame) -> str:
    """The table as Markdown (rich's MARKDOWN box), for docs/capacity.md."""
    from rich import box
    from rich.console import Console
    from rich.table import Table

    out = Table(box=box.MARKDOWN, show_edge=True)
    for name in table.columns:
        out.add_column(str(name), justify="right" if pd.api.types.is_numeric_dtype(table[name]) else "left")
    for values in table.itertuples(index=False):
        out.add_row(*("" if v is None or (isinstance(v, float) and v != v) else str(v) for v in values))
    text = io.StringIO()
    Console(width=400, file=text, color_system=None).print(out)
    return "\n".join(line.rstrip() for line in text.getvalue().splitlines()).strip() + "\n"


AGREE_KEYS = ["profile", "count", "strategy", "seed"]


def agreement(event: pd.DataFrame, reference: pd.DataFrame) -> pd.DataFrame:
    """Each mission of `reference` (a lockstep sweep of some of the points) beside the same mission of `event`:
    uptime, depleted aMussels and the kept-alive verdict on both platforms."""
    both = reference.merge(event, on=AGREE_KEYS, suffixes=(" L", " E"), how="left", validate="one_to_one")
    if both["alive E"].isna().any():
        missing = both[both["alive E"].isna()].iloc[0]
        raise ValueError(f"the event sweep has no mission {', '.join(f'{k} {missing[k]}' for k in AGREE_KEYS)}")
    out = both[AGREE_KEYS].copy()
    for key in ("uptime_avg", "uptime_min", "depleted", "alive"):
        out[f"{key} L"], out[f"{key} E"] = both[f"{key} L"], both[f"{key} E"]
    return out


def agreement_summary(table: pd.DataFrame) -> str:
    same = int((table["alive L"] == table["alive E"]).sum())
    d_avg = (table["uptime_avg L"] - table["uptime_avg E"]).abs().max()
    d_min = (table["uptime_min L"] - table["uptime_min E"]).abs().max()
    d_dep = (table["depleted L"] - table["depleted E"]).abs().max()
    return (f"{len(table)} missions in both: the same kept-alive verdict in {same}; largest differences: "
            f"{d_avg:.2f} pp of average uptime, {d_min:.2f} pp of minimum uptime, {d_dep:g} aMussels depleted")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m gcs.sweep.capacity", description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path, help="the capacity sweep's folder (vil sweep ... --out DIR)")
    parser.add_argument("--figure", type=Path, help="write the figure here (PNG)")
    parser.add_argument("--against", type=Path, metavar="DIR",
                        help="a sweep of some of the same missions on the other platform (lockstep): each beside "
                             "its own, and how far apart")
    args = parser.parse_args(argv)
    try:
        rows = read_missions(args.folder)
        if args.against is not None:
            table = agreement(rows, read_missions(args.against))
            print(markdown(table))
            print(agreement_summary(table))
            return 0
    except (OSError, ValueError, KeyError) as exc:
        print(f"capacity: {exc}", file=sys.stderr)
        return 2
    print(markdown(capacity_table(rows)))
    print(markdown(rows.drop(columns=["days", "sim_days"])))
    if args.figure:
        figure(rows, args.figure)
        print(f"\nfigure: {args.figure}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
