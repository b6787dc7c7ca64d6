"""How the `vil sweep` and Dask examples run and what of their claims is checked (the registry's "sweeps"
room). A Dask cluster costs seconds of CPU to start: these run under the long marker (doc_registry.py says
why), and the default run checks what the shipped spec holds (`check_shipped_spec`)."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

from doc_harness import Work, ports_held, words

STRATEGIES_SWEEP = "vil sweep missions/sweeps/strategies.toml --out sweeps/strategies"
STRATEGIES_SEEDS2 = "vil sweep missions/sweeps/strategies.toml --out sweeps/strategies --seeds 2"
QUICK_SWEEP = "vil sweep missions/sweeps/quick.toml --out sweeps/quick"
KEEP_RUNS = "vil sweep SPEC.toml --out DIR --keep-runs"
REPORT = "vil sweep report DIR"
ON_CLUSTER = "vil sweep SPEC.toml --out DIR --scheduler tcp://HOST:8786"
SCHEDULER = "dask scheduler --port 8786"
WORKER = "dask worker tcp://HOST:8786 --nthreads 1"
ONE_SPEC = "one.toml"
SLACK_SWEEP = "vil sweep docs/examples/slack_sweep.toml --out sweeps/slack"
REPORT_FILES = ("summary.csv", "summary.md", "pareto.png", "uptime.png", "active.png")


def write_one_spec(w: Work) -> None:
    """SPEC.toml of the examples that name it: one 2-minute pool12 mission."""
    (w.path / ONE_SPEC).write_text('[sweep]\nscenarios = ["pool12"]\nstrategies = ["greedy"]\nseeds = "1-1"\n'
                                   '[set]\nmission.duration = "2m"\n')


def check_shipped_spec(root: Path) -> int:
    """missions/sweeps/strategies.toml is what both docs say: every registered strategy x pool12, bay24 x
    seeds 1-20, as many missions as the README's claim; the number of missions."""
    from gcs.strategies import shipped_names
    from gcs.sweep.cells import make_cells
    from gcs.sweep.spec import load_spec

    spec = load_spec(root / "missions/sweeps/strategies.toml")
    cells = make_cells(spec)
    strategies = shipped_names()
    assert spec.seeds == tuple(range(1, 21)) and set(spec.scenarios) == {"pool12", "bay24"} and spec.draw_fleet
    assert {(c.scenario.name, c.strategy) for c in cells} == {(s, n) for s in ("pool12", "bay24") for n in strategies}
    claimed = re.search(r"(\d+) missions", _readme_claim(STRATEGIES_SWEEP)).group(1)  # type: ignore[union-attr]
    assert len(cells) == int(claimed) == 2 * 20 * len(strategies), (len(cells), claimed)
    return len(cells)


def run_strategies_sweep(w: Work) -> None:
    """The shipped spec on its first 2 seeds (--seeds 2: every strategy, pool12 and bay24, seeds 1-2), then
    the whole spec into the same folder runs only the rest: one row per mission (360: seeds 1-20), and
    `vil sweep report DIR` on it writes the tables and plots again."""
    import pandas as pd

    n = check_shipped_spec(w.path)
    first = w.sh(w.line(STRATEGIES_SEEDS2), timeout_s=3600).stdout
    sweep = w.line(STRATEGIES_SWEEP)
    out = w.path / sweep.split("--out ")[1].split()[0]
    two = pd.read_parquet(out / "results.parquet")
    assert set(two["seed"]) == {1, 2} and len(two) == n // 10, first
    assert f"{n // 10} missions, 0 already in" in words(first)
    again = w.sh(sweep, timeout_s=3600).stdout
    assert f"{n} missions, {n // 10} already in" in words(again), again
    rows = pd.read_parquet(out / "results.parquet")
    assert len(rows) == n and len(set(zip(rows["scenario"], rows["strategy"], rows["seed"], strict=True))) == n

    report = w.line(REPORT)
    assert w.path / report.split()[-1] == out
    shutil.rmtree(out / "report")  # what the report example writes, it writes itself
    printed = words(w.sh(report, timeout_s=600).stdout)
    assert all((out / "report" / name).stat().st_size for name in REPORT_FILES)
    assert "means with 95 % intervals" in printed and "lookahead" in printed


def run_quick_sweep(w: Work) -> None:
    """The first sweep both docs point at: the paper's three strategies on pool12, fleets of seeds 1-5, 40
    minutes: 15 rows, and the report's table of the three configurations."""
    import pandas as pd

    line = w.line(QUICK_SWEEP)
    printed = words(w.sh(line, timeout_s=1200).stdout)
    rows = pd.read_parquet(w.path / line.split("--out ")[1].split()[0] / "results.parquet")
    assert len(rows) == 15 and set(rows["strategy"]) == {"cautious", "greedy", "none"} and set(rows["seed"]) == {
        1, 2, 3, 4, 5}
    assert (rows["duration_s"] == 2400).all() and set(rows["scenario"]) == {"pool12"}
    assert "quick (lockstep platform): means with 95 % intervals" in printed
    assert all(f"pool12 {s} 5 " in printed for s in ("cautious", "greedy", "none")), printed


def run_keep_runs(w: Work) -> None:
    """--keep-runs also keeps each mission's folder (its .tlog and logs) in DIR/runs/, named in its row."""
    import pandas as pd

    write_one_spec(w)
    line = w.line(KEEP_RUNS)
    out = w.path / line.split("--out ")[1].split()[0]
    w.sh(line, timeout_s=600)
    rows = pd.read_parquet(out / "results.parquet")
    runs = [p for p in (out / "runs").iterdir() if p.is_dir()]
    assert len(runs) == len(rows) == 1 and Path(rows["run_dir"][0]).name == runs[0].name
    assert (runs[0] / "gcs.tlog").stat().st_size and (runs[0] / "events.jsonl").stat().st_size
    assert list(runs[0].glob("apad1.*")), "the aPad's own .tlog and event log"


def _readme_claim(command: str) -> str:
    from doc_examples import all_examples

    return next(e.claim for e in all_examples() if e.command == command and e.doc == "README.md")


def run_cluster(w: Work) -> None:
    """A Dask scheduler and a worker started as the doc says, and a sweep on that cluster: it says where it
    ran, and its rows are written."""
    import pandas as pd

    write_one_spec(w)
    with ports_held(8786, kind="tcp"):
        scheduler = w.start(w.line(SCHEDULER))
        worker = None
        try:
            scheduler.wait_output(r"Scheduler at:\s+tcp://[\d.]+:8786", 60)
            worker = w.start(w.line(WORKER))
            worker.wait_output(r"Registered to:\s+tcp://127\.0\.0\.1:8786", 60)
            done = words(w.sh(w.line(ON_CLUSTER), timeout_s=300).stdout)
        finally:
            if worker is not None:
                worker.stop()
            scheduler.stop()
    assert "on tcp://127.0.0.1:8786 (1 workers, 1 threads)" in done, done
    out = w.path / w.line(ON_CLUSTER).split("--out ")[1].split()[0]
    rows = pd.read_parquet(out / "results.parquet")
    assert list(zip(rows["scenario"], rows["strategy"], rows["seed"], strict=True)) == [("pool12", "greedy", 1)]
    assert json.loads(next((out / "cells").glob("*.json")).read_text())


def run_slack_sweep(w: Work) -> None:
    """a strategy of one's own swept against three shipped ones: the sweep ends with the Pareto table
    docs/strategies.md shows (the same configurations, n, means, intervals and front marks)."""
    printed = w.sh(w.line(SLACK_SWEEP), timeout_s=3600).stdout
    doc = (w.path / "docs/strategies.md").read_text().split("The sweep ends with its Pareto table", 1)[1]
    sample = doc.split("```", 2)[1]
    rows = [words(line) for line in sample.splitlines() if line.strip().startswith("pool12")]
    assert len(rows) == 4
    got = [words(line) for line in printed.splitlines() if line.strip().startswith("pool12")]
    assert got == rows, printed


CAPACITY_SWEEP = "vil sweep missions/sweeps/capacity.toml --out sweeps/capacity --workers 2"
CAPACITY_REPORT = "python -m gcs.sweep.capacity sweeps/capacity --figure docs/capacity.png"
CAPACITY_LOCKSTEP = "vil sweep missions/sweeps/capacity-lockstep.toml --out sweeps/capacity-lockstep --workers 2"
CAPACITY_AGREE = "python -m gcs.sweep.capacity sweeps/capacity --against sweeps/capacity-lockstep"
CAPACITY_TINY, CAPACITY_LOCKSTEP_TINY = "capacity-tiny.toml", "capacity-lockstep-tiny.toml"


def write_capacity_tiny(w: Work) -> None:
    """The shipped capacity specs' shape (bay-capacity, [[grid]] per profile, their strategies and platforms)
    on 3-minute missions, the smallest size of each profile, one seed: the CI variant of both sweeps."""
    for name, tiny in (("capacity", CAPACITY_TINY), ("capacity-lockstep", CAPACITY_LOCKSTEP_TINY)):
        spec = (w.path / f"missions/sweeps/{name}.toml").read_text()
        spec = re.sub(r'mission\.duration = "24h"', 'mission.duration = "3m"', spec)
        spec = re.sub(r"seeds = \S+", "seeds = [1]", spec)
        spec = re.sub(r"fleet\.count = \[(\d+)[^]]*\]", r"fleet.count = [\1]", spec)
        (w.path / tiny).write_text(spec.replace('"bay-capacity"', f'"{w.path}/missions/bay-capacity.toml"'))


def run_capacity(w: Work) -> None:
    """docs/capacity.md's study: the lockstep spec's points are some of the event spec's, a sweep of each
    shape runs on a local Dask cluster, the capacity report prints the table and writes the figure from its
    cells, and --against sets each lockstep mission beside its event twin."""
    from gcs.sweep.spec import load_spec

    event, lockstep = (load_spec(w.path / f"missions/sweeps/{name}.toml") for name in ("capacity", "capacity-lockstep"))
    assert (str(event.platform), str(lockstep.platform)) == ("event", "lockstep")
    assert all(p in event.points for p in lockstep.points) and set(lockstep.seeds) <= set(event.seeds)
    assert set(lockstep.strategies or ()) <= set(event.strategies or ())
    write_capacity_tiny(w)
    for command in (CAPACITY_SWEEP, CAPACITY_LOCKSTEP):
        w.sh(w.line(command), timeout_s=3600)
    report = w.line(CAPACITY_REPORT)
    printed = words(w.sh(report, timeout_s=600).stdout)
    assert "largest kept alive" in printed and "keep_alive" in printed and "hourly_wake" in printed, printed
    figure = w.path / report.split("--figure ")[1].split()[0]
    assert figure.read_bytes()[:4] == b"\x89PNG"
    assert "the same kept-alive verdict in" in words(w.sh(w.line(CAPACITY_AGREE), timeout_s=600).stdout)


SENSITIVITY_SWEEP = "vil sweep missions/sweeps/sensitivity.toml --out sweeps/sensitivity --workers 2"
SENSITIVITY_REPORT = "vil sweep report sweeps/sensitivity"
SENSITIVITY_FIRST = "vil sweep missions/sweeps/sensitivity.toml --out sweeps/sensitivity --workers 2 --base-samples 64"
SENSITIVITY_TINY = "sensitivity-tiny.toml"


def run_sensitivity(w: Work) -> None:
    """docs/sensitivity.md's study in short form (its fields, bounds and outputs; n = 2, 3-minute missions) on
    a local Dask cluster, then its report again: the indices of every field for every output."""
    spec = (w.path / "missions/sweeps/sensitivity.toml").read_text()
    spec = spec.replace("n = 256", "n = 2").replace('mission.duration = "6h"', 'mission.duration = "3m"')
    (w.path / SENSITIVITY_TINY).write_text(spec.replace('"bay-capacity"', f'"{w.path}/missions/bay-capacity.toml"'))
    first = words(w.sh(w.line(SENSITIVITY_FIRST), timeout_s=3600).stdout)
    assert "sobol indices over 8 fields, 18 points (n = 1)" in first, first
    whole = words(w.sh(w.line(SENSITIVITY_SWEEP), timeout_s=3600).stdout)
    assert "36 missions, 18 already in" in whole and "sobol indices over 8 fields, 36 points" in whole, whole
    again = words(w.sh(w.line(SENSITIVITY_REPORT), timeout_s=600).stdout)
    assert "apad.home_charge_w" in again and "uptime_min" in again, again


TUNE = "vil tune missions/tune/cautious-40.toml --out tune/cautious-40 --workers 2"
TUNE_RUN = "vil run tune/cautious-40/best.toml --duration 24h --platform event"
TUNE_TINY = "tune-tiny.toml"


def run_tuning(w: Work) -> None:
    """docs/tuning.md's example in short form (its scenario, strategy, search space and objective; 3 trials of
    one 10-minute mission, 2 held-out seeds): the study, best.toml, the held-out table, and `vil run` of the
    best policy."""
    spec = (w.path / "missions/tune/cautious-40.toml").read_text()
    spec = (spec.replace("trials = 40", "trials = 3").replace('seeds = "1-3"', "seeds = [1]")
            .replace('held_out = "101-120"', 'held_out = "101-102"')
            .replace('mission.duration = "24h"', 'mission.duration = "10m"'))
    (w.path / TUNE_TINY).write_text(spec.replace('"bay-capacity"', f'"{w.path}/missions/bay-capacity.toml"'))
    printed = words(w.sh(w.line(TUNE), timeout_s=3600).stdout)
    assert "3 trials: best uptime_min" in printed and "2 held-out seeds (101-102)" in printed, printed
    ran = words(w.sh(w.line(TUNE_RUN), timeout_s=600).stdout)
    assert "bay-capacity-cautious-40" in ran and "cautious" in ran, ran


ACOUSTIC_SWEEP = "vil sweep missions/sweeps/acoustic.toml --out sweeps/acoustic --workers 2"
ACOUSTIC_COMPARE = "python -m gcs.sweep.acoustic_compare sweeps/acoustic"
ACOUSTIC_TINY = "acoustic-tiny.toml"


def run_acoustic_sweep(w: Work) -> None:
    """docs/acoustic.md's sweep: the shipped spec is pool12 and bay24, every strategy, seeds 1-20, the
    channel off and on; a sweep of its grid runs on a local Dask cluster and the table compares off and
    on per strategy, naming the one that holds up best."""
    from gcs.sweep.spec import load_spec

    spec = load_spec(w.path / "missions/sweeps/acoustic.toml")
    assert spec.scenarios == ("pool12", "bay24") and spec.strategies is None and spec.seeds == tuple(range(1, 21))
    assert spec.points == ({"acoustic.enabled": False}, {"acoustic.enabled": True})
    text = (w.path / "missions/sweeps/acoustic.toml").read_text()
    tiny = text.replace('scenarios = ["pool12", "bay24"]', f'scenarios = ["{w.path}/missions/pool12.toml"]')
    tiny = tiny.replace('strategies = "all"', 'strategies = ["cautious"]').replace('seeds = "1-20"', "seeds = [1]")
    (w.path / ACOUSTIC_TINY).write_text(tiny + '\n[set]\nmission.duration = "5m"\n')
    w.sh(w.line(ACOUSTIC_SWEEP), timeout_s=3600)
    printed = words(w.sh(w.line(ACOUSTIC_COMPARE), timeout_s=600).stdout)
    assert "uptime off % | uptime on %" in printed and "| pool12 | cautious | 1 |" in printed, printed
    assert "pool12: best with the channel on: cautious" in printed, printed
