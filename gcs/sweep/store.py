"""What a sweep leaves in its folder, and the tables built from it.

    DIR/cells/KEY.json     one per finished mission, written whole or not at all (resume skips it)
    DIR/sweep.json         the sweep's name, spec, swept fields and order of scenarios and strategies
    DIR/results.parquet    one row per mission, in the spec's order (`pandas.read_parquet` as it is)
    DIR/results.csv        the same rows
    DIR/active.parquet     each mission's active count over mission time (long: one row per bin)
    DIR/runs/              each mission's own folder, only with --keep-runs
"""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pandas as pd

from gcs.sweep.cells import Cell
from gcs.sweep.flatten import flatten
from gcs.sweep.spec import SweepSpec

CELLS = "cells"
RESULTS = "results"
ACTIVE = "active.parquet"
SWEEP = "sweep.json"
# Every row starts with these; then the swept fields, then result.json flattened.
IDENTITY = ("cell", "scenario", "strategy", "seed")
# result.json fields that are the cell's own identity or say where the run was, not what it did.
NOT_FIGURES = ("scenario", "strategy", "seed", "out_dir")


class StoreError(OSError):
    """A sweep folder that cannot be read as one (a missing or broken file)."""


def cell_path(out: Path, key: str) -> Path:
    return out / CELLS / f"{key}.json"


def finished(out: Path) -> set[str]:
    """The keys of the cells already in DIR."""
    folder = out / CELLS
    return {p.stem for p in folder.glob("*.json")} if folder.is_dir() else set()


@contextmanager
def atomic(path: Path) -> Iterator[Path]:
    """Write `path` whole or not at all: the caller writes the temporary file beside it that this
    renames over it when the block ends without an error."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".part", dir=path.parent)
    os.close(fd)
    tmp = Path(name)
    try:
        yield tmp
        tmp.chmod(0o644)  # mkstemp makes it private; the sweep's files are for everyone who reads DIR
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def write_cell(out: Path, cell: Cell, outcome: dict[str, Any]) -> None:
    """A finished mission: its inputs, result.json and active-count series."""
    record = {"key": cell.key, "scenario": cell.scenario.name, "strategy": cell.strategy, "seed": cell.seed,
              "values": cell.values, **outcome}
    with atomic(cell_path(out, cell.key)) as tmp:
        tmp.write_text(json.dumps(record, separators=(",", ":")), encoding="utf-8")


def read_cells(out: Path) -> list[dict[str, Any]]:
    """Every finished mission's record in `out`/cells, in file order (a sweep still running: those done);
    FileNotFoundError naming the folder if there is none."""
    paths = sorted((out / CELLS).glob("*.json"))
    if not paths:
        raise FileNotFoundError(f"{out}: no finished missions in {out / CELLS} (run the sweep first)")
    return [json.loads(p.read_text(encoding="utf-8")) for p in paths]


def read_cell(out: Path, key: str) -> dict[str, Any]:
    path = cell_path(out, key)
    try:
        record: dict[str, Any] = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as exc:
        raise StoreError(f"{path}: cannot read the cell: {exc}") from None
    return record


def write_sweep(out: Path, spec: SweepSpec, cells: list[Cell]) -> None:
    meta: dict[str, Any] = {"name": spec.name, "spec": str(spec.path), "swept": list(spec.swept),
            "scenarios": list(dict.fromkeys(c.scenario.name for c in cells)),
            "strategies": list(dict.fromkeys(c.strategy for c in cells)), "cells": len(cells)}
    if spec.sensitivity is not None:  # what `gcs.sweep.sensitivity` analyses the rows with
        meta["sensitivity"] = spec.sensitivity.to_json()
        meta["points"] = list(spec.points)  # the sample as run, in its order (a later SALib may draw others)
        meta["keys"] = [c.key for c in cells]  # its missions: the folder may hold others' (a spec changed)
    with atomic(out / SWEEP) as tmp:
        tmp.write_text(json.dumps(meta, indent=1) + "\n", encoding="utf-8")


def read_sweep(out: Path) -> dict[str, Any]:
    try:
        meta: dict[str, Any] = json.loads((out / SWEEP).read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise StoreError(f"{out}: not a sweep folder (no {SWEEP}; run vil sweep SPEC --out {out} first)") from None
    except (OSError, json.JSONDecodeError) as exc:
        raise StoreError(f"{out / SWEEP}: cannot read: {exc}") from None
    return meta


def row(record: dict[str, Any], swept: tuple[str, ...]) -> dict[str, Any]:
    """One table row of a cell record: identity, swept values, then every figure of its result."""
    figures = {k: v for k, v in flatten(record["result"]).items() if k not in NOT_FIGURES}
    values = {k: _scalar(record["values"].get(k)) for k in swept}
    clash = sorted(set(values) & set(figures))
    if clash:
        raise StoreError(f"swept field {clash[0]} has the name of a result column")
    kept = {"run_dir": record["result"]["out_dir"]} if record["result"].get("out_dir") else {}  # --keep-runs
    return {"cell": record["key"], "scenario": record["scenario"], "strategy": record["strategy"],
            "seed": record["seed"], **values, **figures, **kept}


def _scalar(value: Any) -> Any:
    """A column value: lists (e.g. a start_battery pair) as JSON text, so every column has one type."""
    return json.dumps(value) if isinstance(value, list | dict) else value


def write_results(out: Path, cells: list[Cell], swept: tuple[str, ...]) -> pd.DataFrame:
    """results.parquet, results.csv and active.parquet from the cells' files, in the spec's order."""
    records = [read_cell(out, c.key) for c in sorted(cells, key=lambda c: c.index)]
    table = pd.DataFrame([row(r, swept) for r in records])
    counts = [c for c in table.columns if "=" in c]  # a word no run of a cell had is 0 there, not missing
    table[counts] = table[counts].fillna(0).astype("int64")
    series = pd.DataFrame([
        {"cell": r["key"], "scenario": r["scenario"], "strategy": r["strategy"], "seed": r["seed"],
         **{k: _scalar(r["values"].get(k)) for k in swept}, "t_s": t, "active": a}
        for r in records for t, a in zip(r["series"]["t_s"], r["series"]["active"], strict=True)
    ])
    with atomic(out / f"{RESULTS}.parquet") as tmp:
        table.to_parquet(tmp, index=False)
    with atomic(out / f"{RESULTS}.csv") as tmp:
        table.to_csv(tmp, index=False)
    with atomic(out / ACTIVE) as tmp:
        series.to_parquet(tmp, index=False)
    return table
