"""result.json's types: a run's Table II indices and what it says besides, the paper's own figures, and the
spread over seeds. Data only: `gcs.cli.tables` prints them."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

# The paper's Table II (40 min, theta = 30): avg %, max %, min %, cost m, active.
PAPER_TABLE_II: dict[tuple[str, str], tuple[float, float, float, float, float]] = {
    ("pool12", "cautious"): (74.37, 87.38, 59.88, 307.1746, 8.9243),
    ("pool12", "greedy"): (72.27, 87.16, 42.84, 247.8026, 8.9495),
    ("bay24", "greedy"): (71.98, 90.31, 31.18, 186.4318, 16.2368),
    ("pool12", "none"): (67.36, 79.56, 56.64, 0.0, 8.0837),
}
PAPER_DURATION_S = 2400.0
PAPER_THETA = 30.0


def paper_figures(scenario: str, strategy: str, duration_s: float, theta: float) -> tuple[float, ...] | None:
    """The paper's Table II row for a run of the same scenario and strategy, only if it ran as the
    paper's did (40 minutes at theta 30): a 6-hour run's figures are not comparable to it."""
    if duration_s != PAPER_DURATION_S or theta != PAPER_THETA:
        return None
    return PAPER_TABLE_II.get((scenario, strategy))


@dataclass(frozen=True)
class MusselResult:
    id: int
    start_battery: float
    uptime_pct: float
    dockings: list[dict[str, Any]] = field(default_factory=list)  # each {"t_s", "apad"} that docked it
    state_s: dict[str, float] = field(default_factory=dict)  # seconds in each state; they sum to the mission time
    first_depleted_s: float | None = None  # mission time it first depleted; None: never
    # Its behaviour profile at the end (mussel_sim.behaviour; a sleep order's shows as "PROFILE+order:..."),
    # and the wakes of its schedule: ACTIVE on the seabed at the time / all (0 and 0: always on).
    profile: str = "always_on"
    samples_taken: int = 0
    samples_scheduled: int = 0


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
    whereabouts: list[dict[str, Any]] = field(default_factory=list)  # every aMussel at the end (gcs.results.accounting)
    # What happened that a user would want to know: faults injected, failsafe holds, link losses,
    # aPads lost, re-shares, steps given up (`gcs.mission.outcome.happenings`)
    happened: dict[str, Any] = field(default_factory=dict)
    # One row per aPad (gcs.mission.outcome.apad_rows), with its travelling, docking and holding shares
    # of the mission time (gcs.mission.time_accounting).
    apads: list[dict[str, Any]] = field(default_factory=list)
    # Per simulated day (86,400 s / theta of mission time; `gcs.results.days.day_rows`), every day
    sim_day_s: float = 0.0
    days: list[dict[str, Any]] = field(default_factory=list)
    # An acoustic scenario's channel: the TDMA frame and slot table, reports sent and heard, call-ups,
    # drops by reason, and belief against truth (`gcs.acoustic_net.network.AcousticNetwork.summary`); {}: WiFi only
    acoustic: dict[str, Any] = field(default_factory=dict)
    # What it ran on (gcs.mission.platform): "lockstep" (every byte on the wire) or "event" (discrete events)
    platform: str = "lockstep"

    def to_json(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> RunResult:
        """The result `to_json` wrote (a run's result.json read back)."""
        return cls(**{**data, "mussels": [MusselResult(**m) for m in data["mussels"]]})

    @property
    def misplaced(self) -> list[dict[str, Any]]:
        """The aMussels that did not end where they should: left at the surface, off their
        position, or docked where the GCS does not know (gcs.results.accounting)."""
        return [w for w in self.whereabouts if w["where"] == "lost"]


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


def fraction_of_seeds(results: list[RunResult], scenario: str, claim: Callable[[RunResult, RunResult], bool],
                      a: str, b: str) -> tuple[int, int]:
    """(seeds where `claim(run_a, run_b)` holds, seeds with both runs) for one scenario."""
    by = {(r.strategy, r.seed): r for r in results if r.scenario == scenario}
    seeds = sorted({seed for strategy, seed in by if strategy == a and (b, seed) in by})
    return sum(claim(by[(a, s)], by[(b, s)]) for s in seeds), len(seeds)


# The robust shape of Table II, and the one comparison the paper's single run cannot settle.
SHAPE_CLAIMS: tuple[tuple[str, str, str, Callable[[RunResult, RunResult], bool]], ...] = (
    ("cautious beats no charging (avg uptime)", "cautious", "none", lambda a, b: a.uptime["avg"] > b.uptime["avg"]),
    ("cautious lifts the minimum above greedy", "cautious", "greedy", lambda a, b: a.uptime["min"] > b.uptime["min"]),
    ("greedy moves less than cautious", "greedy", "cautious", lambda a, b: a.cost_m < b.cost_m),
    ("greedy beats no charging (avg uptime)", "greedy", "none", lambda a, b: a.uptime["avg"] > b.uptime["avg"]),
)


