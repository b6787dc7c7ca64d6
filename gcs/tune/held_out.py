"""What a `vil tune` study found, as files a user takes on: the best policy as a scenario `vil run` runs, and
that policy against the baseline on seeds it was never tuned on.

DIR/best.toml: the spec's scenario with [set], the best trial's fields and its strategy (its `area` and
`start_config` found from DIR). DIR/held_out.csv and .md: per policy (tuned, baseline) and per output, the
mean over the held-out seeds with its 95 % interval, and the tuned policy's difference paired seed by seed.
"""

from __future__ import annotations

import os
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import tomli_w
from rich import box
from rich.table import Table

from gcs.scenario.reader import load_scenario
from gcs.sweep.cells import Cell, make_cells, patched
from gcs.sweep.outputs import output_values, ran_flat
from gcs.sweep.spec import Value
from gcs.sweep.stats import mean_ci
from gcs.tune.spec import TuneSpec

BEST, TABLE_CSV, TABLE_MD = "best.toml", "held_out.csv", "held_out.md"
SHOWN = ("uptime_min", "uptime_avg", "alive_at_end", "samples_taken_pct", "dockings_per_day", "apad_wh_per_day")


def best_scenario(spec: TuneSpec, params: dict[str, Value], out: Path) -> Path:
    """Write DIR/best.toml: the tuned policy as a scenario file. The study's missions drew their fleets from their
    seeds, so it names no saved start: `vil run DIR/best.toml --seed N` is the study's mission of seed N."""
    base = load_scenario(spec.path.parent / spec.scenario if (spec.path.parent / spec.scenario).is_file()
                         else spec.scenario)
    raw = tomllib.loads(base.path.read_text(encoding="utf-8"))
    data = patched(raw, {**spec.fixed, **params, "mission.collect_strategy": spec.strategy})
    data.setdefault("scenario", {})["name"] = f"{base.name}-{spec.name}"
    fleet = data.setdefault("fleet", {})
    fleet["area"] = _relative(base.fleet.area, out)
    fleet.pop("start_config", None)
    path = out / BEST
    header = (f"# The best policy of `vil tune {spec.path.name}` ({spec.name}): {spec.strategy} with "
              + ", ".join(f"{k} = {v}" for k, v in params.items())
              + f".\n# vil run {path} --seed N --platform {spec.platform}   (seed N's fleet, as the study's)\n")
    path.write_text(header + tomli_w.dumps(data), encoding="utf-8")
    load_scenario(path)  # what `vil run` will read: checked now (ScenarioError), not found broken later
    return path


def _relative(path: Path, folder: Path) -> str:
    try:
        return Path(os.path.relpath(path.resolve(), folder.resolve())).as_posix()
    except ValueError:  # another drive
        return path.resolve().as_posix()


def held_out_cells(spec: TuneSpec, params: dict[str, Value]) -> dict[str, list[Cell]]:
    """The tuned policy's and the baseline's missions on the held-out seeds."""
    return {"tuned": make_cells(spec.sweep(params, spec.held_out)),
            "baseline": make_cells(spec.sweep({}, spec.held_out, spec.baseline))}


def held_out_table(cells: dict[str, list[Cell]], results: dict[str, dict[str, Any]]) -> pd.DataFrame:
    """Per output: each policy's mean with its 95 % half-interval over the seeds, and tuned - baseline paired."""
    per = {policy: pd.DataFrame([output_values(results[c.key]) for c in policy_cells], index=[c.seed for c in
                                                                                                 policy_cells])
           for policy, policy_cells in cells.items()}
    depleted = {policy: sum(1 for c in policy_cells if ran_flat(results[c.key]))
                for policy, policy_cells in cells.items()}
    rows = []
    for output in SHOWN:
        row: dict[str, Any] = {"output": output}
        for policy, frame in per.items():
            row[f"{policy}"], row[f"{policy}_ci95"] = mean_ci(frame[output].to_numpy(np.float64))
        diff = (per["tuned"][output] - per["baseline"][output].reindex(per["tuned"].index)).to_numpy(np.float64)
        row["difference"], row["difference_ci95"] = mean_ci(diff)
        rows.append(row)
    rows.append({"output": "missions with an aMussel run flat", "tuned": float(depleted["tuned"]),
                 "baseline": float(depleted["baseline"])})
    return pd.DataFrame(rows)


def rich_table(table: pd.DataFrame, title: str) -> Table:
    out = Table(title=title, box=box.SIMPLE_HEAD, pad_edge=False, caption="means ± 95 % intervals over the held-out "
                "seeds; the difference paired seed by seed")
    for name in ("output", "tuned", "baseline", "tuned - baseline"):
        out.add_column(name, justify="left" if name == "output" else "right", no_wrap=True)
    for _, r in table.iterrows():
        out.add_row(str(r["output"]), _pm(r, "tuned"), _pm(r, "baseline"), _pm(r, "difference"))
    return out


def markdown(table: pd.DataFrame, title: str) -> str:
    lines = [f"**{title}**", "", "| output | tuned | baseline | tuned - baseline |", "|---|---|---|---|"]
    lines += [f"| {r['output']} | {_pm(r, 'tuned')} | {_pm(r, 'baseline')} | {_pm(r, 'difference')} |"
              for _, r in table.iterrows()]
    return "\n".join(lines) + "\n"


def _pm(row: pd.Series, key: str) -> str:
    value = row.get(key)
    if value is None or pd.isna(value):
        return "-"
    half = row.get(f"{key}_ci95")
    return f"{value:.2f}" if half is None or pd.isna(half) else f"{value:.2f} ± {half:.2f}"
