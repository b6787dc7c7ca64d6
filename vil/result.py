"""One mission's result for Python: the figures as attributes, the tables as pandas frames."""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np
import pandas as pd

from gcs.records.run_folder import RunFolder
from gcs.results.run_result import RunResult
from missiontime import US_PER_S


@dataclass(frozen=True)
class Result:
    """A finished run: `raw` is what result.json holds; `folder` has its logs, .tlogs and traces."""

    raw: RunResult
    folder: Path

    @classmethod
    def read(cls, folder: RunFolder) -> Result:
        return cls(RunResult.from_json(json.loads(folder.result.read_text(encoding="utf-8"))), folder.path)

    # --- the paper's figures (Table II) ------------------------------------------------------------
    @property
    def uptime_avg(self) -> float:
        """Mean aMussel uptime, percent (eq. 3)."""
        return self.raw.uptime["avg"]

    @property
    def uptime_max(self) -> float:
        return self.raw.uptime["max"]

    @property
    def uptime_min(self) -> float:
        return self.raw.uptime["min"]

    @property
    def cost_m(self) -> float:
        """The paper's movement cost: aPad-to-setpoint distances over every Go To, metres."""
        return self.raw.cost_m

    @property
    def active_avg(self) -> float:
        """aMussels active on average over the mission."""
        return self.raw.active_avg

    @property
    def cycles(self) -> int:
        return self.raw.cycles

    @property
    def scenario(self) -> str:
        return self.raw.scenario

    @property
    def strategy(self) -> str:
        return self.raw.strategy

    @property
    def seed(self) -> int:
        return self.raw.seed

    @property
    def duration_s(self) -> float:
        return self.raw.duration_s

    @property
    def happened(self) -> dict[str, object]:
        """Faults injected, failsafe holds, link losses, lost aPads, re-shares (empty: none)."""
        return self.raw.happened

    # --- tables ------------------------------------------------------------------------------------
    @cached_property
    def mussels(self) -> pd.DataFrame:
        """One row per aMussel (index: id): start battery, uptime %, dockings, when it first depleted,
        and its seconds in each state (`s_active`, `s_docked`, ...; they sum to the mission time)."""
        rows = [{"id": m.id, "start_battery": m.start_battery, "uptime_pct": m.uptime_pct, "dockings": len(m.dockings),
                 "first_depleted_s": np.nan if m.first_depleted_s is None else m.first_depleted_s,
                 **{f"s_{state}": s for state, s in m.state_s.items()}} for m in self.raw.mussels]
        return pd.DataFrame(rows).set_index("id")

    @cached_property
    def apads(self) -> pd.DataFrame:
        """One row per aPad (index: system id): its share, travel, dockings, cycles and time shares."""
        rows = [{k: v for k, v in a.items() if not isinstance(v, list | dict)} for a in self.raw.apads]
        return pd.DataFrame(rows).set_index("sysid") if rows else pd.DataFrame()

    @cached_property
    def days(self) -> pd.DataFrame:
        """One row per simulated day (index: day, 1 = the first; each 86,400 s / theta of mission time):
        from_s, to_s, uptime_pct, alive, depleted, and per aPad N `charges_N` and `passed_wh_N`;
        empty for a run that kept none (older runs)."""
        rows = [{k: v for k, v in d.items() if not isinstance(v, dict)}
                | {f"{k}_{a}": x for k in ("charges", "passed_wh") for a, x in d.get(k, {}).items()}
                for d in self.raw.days]
        return pd.DataFrame(rows).set_index("day") if rows else pd.DataFrame()

    @cached_property
    def active(self) -> pd.DataFrame:
        """Active aMussels at each fleet step: columns `t_s` (mission seconds) and `active`."""
        with np.load(RunFolder(self.folder).traces) as traces:
            t_us, count = traces["step_time_us"], traces["active_count"]
        return pd.DataFrame({"t_s": t_us / US_PER_S, "active": count})

    def __repr__(self) -> str:
        return (f"Result({self.scenario} {self.strategy} seed {self.seed}: uptime {self.uptime_avg:.2f} % avg, "
                f"cost {self.cost_m:.1f} m, {self.folder})")
