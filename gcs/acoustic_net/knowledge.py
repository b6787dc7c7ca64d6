"""What the GCS believes of an aMussel it hears only now and then, and how far that belief is from the truth.

`believed_battery` is the estimate the planner plans with in an acoustic scenario: the battery last
heard, run down by the aMussel's drain (eq. 1, its duty) over the time since; at the surface (WiFi)
the planner runs it forward in the model's steps instead (`gcs.belief.foresight`).
`KnowledgeLedger` samples belief against the simulator's truth during a run, for the records: each
aMussel's estimate error, and the age of what was known (median from a histogram of fixed bins,
maximum exact), in bounded memory whatever the duration.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from gcs.link.telemetry import MusselView
from missiontime import US_PER_S
from mussel_sim.vocabulary import MusselState

UNDERWATER = frozenset({MusselState.ACTIVE, MusselState.SURFACING, MusselState.SINKING})
AGE_BIN_S = 0.5
AGE_BINS = 14_400  # two hours of ages in half seconds; older lands in the last bin (its maximum is exact)


def age_s(view: MusselView, now_us: int) -> float:
    """Mission seconds since the report `view` holds was made."""
    return max(now_us - view.time_us, 0) / US_PER_S


def run_down_start(report_us: int, report_frac: float, anchor: tuple[int, float] | None) -> tuple[int, float]:
    """Where an estimate's run-down starts, (mission us, battery): the report, or `anchor`, what was
    believed when the aMussel's duty last changed (a sleep order), if that came after the report."""
    return (report_us, report_frac) if anchor is None or anchor[0] <= report_us else anchor


def believed_battery(view: MusselView, now_us: int, drain_per_s: float,
                     anchor: tuple[int, float] | None = None) -> float:
    """Its battery now as the GCS can know it: under water, the report run down at `drain_per_s`
    since it was made (never below empty); at the surface or depleted, as reported (the planner runs
    those forward in the model's steps: `gcs.belief.foresight`). `anchor`: (mission us, battery)
    believed when its duty last changed (a sleep order); after the report, the run-down at
    `drain_per_s` (the new duty's) starts there, the old duty's having run to it."""
    if view.state not in UNDERWATER:
        return view.battery_frac
    since_us, battery = run_down_start(view.time_us, view.battery_frac, anchor)
    return max(battery - drain_per_s * max(now_us - since_us, 0) / US_PER_S, 0.0)


@dataclass(frozen=True)
class KnowledgeSummary:
    samples: int
    age_median_s: float
    age_max_s: float
    error_mean: float  # |belief - truth| of the battery fraction, over every sample of every aMussel
    error_max: float
    per_mussel: list[dict[str, float]]  # each heard aMussel's mussel_id, battery_error_mean, _max, age_max_s

    def as_dict(self) -> dict[str, object]:
        return {"samples": self.samples, "age_median_s": self.age_median_s, "age_max_s": self.age_max_s,
                "battery_error_mean": self.error_mean, "battery_error_max": self.error_max,
                "per_mussel": self.per_mussel}


class KnowledgeLedger:
    """Belief against truth for the aMussels `ids`, one `sample` at a time."""

    def __init__(self, ids: NDArray[np.integer]) -> None:
        self.ids = np.asarray(ids, dtype=np.int64)
        n = self.ids.size
        self.n = np.zeros(n, dtype=np.int64)
        self.err_sum = np.zeros(n)
        self.err_max = np.zeros(n)
        self.age_max = np.zeros(n)
        self.ages = np.zeros(AGE_BINS, dtype=np.int64)
        self.samples = 0

    def sample(self, known: NDArray[np.bool_], belief: NDArray[np.float64], truth: NDArray[np.float64],
               age: NDArray[np.float64]) -> None:
        """One sample, each `(n,)` in `ids` order; `known`: heard at least once (the others are skipped)."""
        err = np.abs(belief - truth)
        self.n += known
        self.err_sum += np.where(known, err, 0.0)
        self.err_max = np.where(known, np.maximum(self.err_max, err), self.err_max)
        self.age_max = np.where(known, np.maximum(self.age_max, age), self.age_max)
        bins = np.minimum((age[known] / AGE_BIN_S).astype(np.int64), AGE_BINS - 1)
        self.ages += np.bincount(bins, minlength=AGE_BINS)
        self.samples += 1

    def summary(self) -> KnowledgeSummary:
        total = int(self.ages.sum())
        if total == 0:
            return KnowledgeSummary(self.samples, 0.0, 0.0, 0.0, 0.0, [])
        median_bin = int(np.searchsorted(np.cumsum(self.ages), (total + 1) / 2))
        heard = self.n > 0
        per = [{"mussel_id": m, "battery_error_mean": round(float(self.err_sum[k] / self.n[k]), 6),
                "battery_error_max": round(float(self.err_max[k]), 6), "age_max_s": round(float(self.age_max[k]), 2)}
               for k, m in enumerate(self.ids.tolist()) if heard[k]]
        return KnowledgeSummary(
            self.samples, (median_bin + 0.5) * AGE_BIN_S, float(self.age_max.max()),
            float(self.err_sum.sum() / self.n.sum()), float(self.err_max.max()), per)
