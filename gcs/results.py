"""Run results: the paper's Table II indices, as JSON and as rich tables beside the paper's figures."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
from rich.table import Table

# The paper's Table II (40 min, theta = 30): avg %, max %, min %, cost m, active.
PAPER_TABLE_II: dict[tuple[str, str], tuple[float, float, float, float, float]] = {
    ("pool12", "cautious"): (74.37, 87.38, 59.88, 307.1746, 8.9243),
    ("pool12", "greedy"): (72.27, 87.16, 42.84, 247.8026, 8.9495),
    ("bay24", "greedy"): (71.98, 90.31, 31.18, 186.4318, 16.2368),
    ("pool12", "none"): (67.36, 79.56, 56.64, 0.0, 8.0837),
}
PAPER_LABELS = {
    ("pool12", "cautious"): "Cautious, 12 in pool",
    ("pool12", "greedy"): "Greedy, 12 in pool",
    ("bay24", "greedy"): "Greedy, 24 in bay",
    ("pool12", "none"): "No charging, 12",
}


@dataclass(frozen=True)
class MusselResult:
    id: int
    start_battery: float
    uptime_pct: float


@dataclass(frozen=True)
class RunResult:
    scenario: str
    strategy: str
    seed: int
    theta: float
    duration_s: float
    uptime: dict[str, float]  # avg, max, min in percent (eq. 3)
    cost_m: float  # the paper's movement cost: aPad-to-setpoint distances over all Go To commands
    active_avg: float  # mean number of active aMussels per step
    wall_s: float
    mussels: list[MusselResult]
    travelled_m: float = 0.0  # what the aPad's odometer says it really moved
    cycles: int = 0  # completed collect-charge-redeploy cycles
    end_reason: str = ""
    out_dir: str = ""
    messages: dict[str, int] = field(default_factory=dict)  # MAVLink counters of the run

    def to_json(self) -> dict[str, Any]:
        return asdict(self)


def _cell(ours: float, paper: float | None, digits: int) -> str:
    mine = f"{ours:.{digits}f}"
    return mine if paper is None else f"{mine} [dim]/ {paper:.{digits}f}[/]"


def results_table(results: list[RunResult], title: str = "Results") -> Table:
    """One row per run; where the paper ran the same thing, its figure follows ours after a slash."""
    table = Table(title=title, caption="ours / paper's Table II, where the paper has the run")
    for col, justify in (("run", "left"), ("avg %", "right"), ("max %", "right"), ("min %", "right"),
                         ("cost m", "right"), ("active", "right"), ("cycles", "right"), ("wall s", "right")):
        table.add_column(col, justify=justify)  # type: ignore[arg-type]
    for r in results:
        paper = PAPER_TABLE_II.get((r.scenario, r.strategy))
        label = PAPER_LABELS.get((r.scenario, r.strategy), f"{r.strategy}, {r.scenario}")
        p = paper or (None,) * 5
        table.add_row(
            f"{label} (seed {r.seed})",
            _cell(r.uptime["avg"], p[0], 2), _cell(r.uptime["max"], p[1], 2), _cell(r.uptime["min"], p[2], 2),
            _cell(r.cost_m, p[3], 1), _cell(r.active_avg, p[4], 2), str(r.cycles), f"{r.wall_s:.2f}",
        )
    return table


@dataclass(frozen=True)
class SeedStats:
    """Mean and spread over seeds of one (scenario, strategy)."""

    scenario: str
    strategy: str
    n: int
    mean: dict[str, float]
    std: dict[str, float]


def _columns(r: RunResult) -> dict[str, float]:
    return {"avg": r.uptime["avg"], "max": r.uptime["max"], "min": r.uptime["min"],
            "cost_m": r.cost_m, "active": r.active_avg}


def seed_stats(results: list[RunResult]) -> list[SeedStats]:
    groups: dict[tuple[str, str], list[RunResult]] = {}
    for r in results:
        groups.setdefault((r.scenario, r.strategy), []).append(r)
    out = []
    for (scenario, strategy), runs in groups.items():
        cols = [_columns(r) for r in runs]
        keys = cols[0].keys()
        out.append(SeedStats(
            scenario, strategy, len(runs),
            {k: float(np.mean([c[k] for c in cols])) for k in keys},
            {k: float(np.std([c[k] for c in cols], ddof=1)) if len(cols) > 1 else 0.0 for k in keys},
        ))
    return out


def seed_stats_table(stats: list[SeedStats], title: str) -> Table:
    table = Table(title=title, caption="mean ± standard deviation over seeds")
    for col in ("scenario", "strategy", "seeds", "avg %", "max %", "min %", "cost m", "active"):
        table.add_column(col, justify="left" if col in ("scenario", "strategy") else "right")
    for s in stats:
        table.add_row(
            s.scenario, s.strategy, str(s.n),
            *(f"{s.mean[k]:.2f} ± {s.std[k]:.2f}" for k in ("avg", "max", "min")),
            f"{s.mean['cost_m']:.1f} ± {s.std['cost_m']:.1f}", f"{s.mean['active']:.2f} ± {s.std['active']:.2f}",
        )
    return table


def fraction_better(results: list[RunResult], scenario: str, a: str, b: str, key: str = "avg") -> float | None:
    """Fraction of seeds where strategy `a` has a higher uptime `key` than `b` (same scenario and seed)."""
    by = {(r.strategy, r.seed): r.uptime[key] for r in results if r.scenario == scenario}
    seeds = sorted({seed for strategy, seed in by if strategy == a and (b, seed) in by})
    if not seeds:
        return None
    return sum(by[(a, s)] > by[(b, s)] for s in seeds) / len(seeds)
