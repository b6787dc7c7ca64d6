"""`vil tune`: search a policy (a strategy's parameters, the aMussels' sleep schedule) for an objective, with
Optuna, each trial's missions on the sweep's Dask cluster; then the best policy against a baseline on
held-out seeds.

    vil tune missions/tune/sleep-schedule.toml --out tune/sleep      # a study; run again to continue it
    vil tune SPEC.toml --out DIR --trials 80                          # more trials than the spec asks
    vil tune SPEC.toml --out DIR --scheduler tcp://HOST:8786          # on a running Dask cluster

The spec (TOML; docs/tuning.md) names the scenario, the strategy, the objective (maximised; with
`no_depleted`, a trial in which an aMussel ran flat is infeasible), the tuning and the held-out seeds,
[set] fields and the [search] space. The study is kept in DIR/study.db: after Ctrl-C, a crash or a kill,
the same command continues it (complete trials and the best value kept; each mission already run is in
DIR/cells). At the end: DIR/best.toml, the best policy as a scenario (`vil run DIR/best.toml`), and
DIR/held_out.csv / .md, the best policy and the baseline on the held-out seeds.

Exit status: 0 done; 1 trials failed (a mission raised, or the objective had no value: listed) or no trial
completed; 2 bad input; 130 interrupted.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

from rich.console import Console

from gcs.cli import flags
from gcs.cli.sweep import MAX_WORKERS
from gcs.cli.tables import output_console
from gcs.scenario.reader import ScenarioError
from gcs.sweep.cluster import ClusterError, dask_client
from gcs.sweep.spec import SpecError
from gcs.tune import held_out as ho
from gcs.tune.spec import MAX_TRIALS, TuneSpec, load_tune_spec
from gcs.tune.study import Best, StudyError, count_complete, run_missions, run_study, study_lock

EXIT_FAILED, EXIT_BAD_INPUT, EXIT_INTERRUPTED = 1, 2, 130


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("spec", metavar="SPEC.toml", help="the tune spec")
    parser.add_argument("--out", type=flags.writable_dir, metavar="DIR", required=True,
                        help="the study's folder: study.db, the missions run, best.toml, held_out.csv/.md")
    parser.add_argument("--trials", type=flags.integer_in(1, MAX_TRIALS), metavar="N",
                        help="complete trials to reach (default: the spec's tune.trials)")
    parser.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                        help="run on this Dask scheduler's workers (default: a local cluster, a worker per core)")
    parser.add_argument("--workers", type=flags.integer_in(1, MAX_WORKERS), metavar="N",
                        help="workers of the local cluster (default: CPU count)")
    parser.add_argument("--no-held-out", action="store_true", help="skip the held-out table at the end")


def run(args: argparse.Namespace) -> int:
    console = output_console()
    if args.scheduler is not None and args.workers is not None:
        return _bad("--workers sizes the local cluster; with --scheduler the cluster has its own")
    try:
        spec = load_tune_spec(args.spec)
        if args.trials is not None:
            spec = _with_trials(spec, args.trials)
        ho.held_out_cells(spec, spec.corner())  # the scenario, [set], [search] and the baseline checked before
        # any cluster starts
    except SpecError as exc:
        return _bad(str(exc))
    out = Path(args.out)
    try:
        with study_lock(out), dask_client(args.scheduler, args.workers) as client:
            outcome = run_study(spec, out, console, client)
            for line in outcome.failed:
                print(f"vil tune: failed: {line}", file=sys.stderr)
            best = outcome.best
            if best is None:
                print("vil tune: no trial completed", file=sys.stderr)
                return EXIT_FAILED
            _say_best(console, spec, best, outcome.complete)
            console.print(f"best policy: {ho.best_scenario(spec, best.params, out)}")
            if not args.no_held_out:
                cells = ho.held_out_cells(spec, best.params)
                results = run_missions([c for group in cells.values() for c in group], out, console, client)
                table = ho.held_out_table(cells, results)
                title = (f"{spec.name}: tuned {spec.strategy} against {spec.baseline}, {len(spec.held_out)} held-out "
                         f"seeds ({spec.held_out[0]}-{spec.held_out[-1]})")
                table.to_csv(out / ho.TABLE_CSV, index=False)
                (out / ho.TABLE_MD).write_text(ho.markdown(table, title), encoding="utf-8")
                console.print(ho.rich_table(table, title))
    except (StudyError, ClusterError, ScenarioError) as exc:
        print(f"vil tune: {exc}", file=sys.stderr)
        return EXIT_FAILED
    except OSError as exc:
        return _bad(f"--out {out}: {exc.strerror or exc}")
    except KeyboardInterrupt:
        print(f"vil tune: interrupted; {count_complete(spec, out)} complete trials are kept in {out}: run it again to "
              "continue", file=sys.stderr)
        return EXIT_INTERRUPTED
    return EXIT_FAILED if outcome.failed else 0


def _with_trials(spec: TuneSpec, trials: int) -> TuneSpec:
    return replace(spec, trials=trials)


def _say_best(console: Console, spec: TuneSpec, best: Best, complete: int) -> None:
    fields = ", ".join(f"{k} = {v:.4g}" if isinstance(v, float) else f"{k} = {v}" for k, v in best.params.items())
    verdict = "" if best.feasible else "; no trial kept every aMussel alive: the best of the infeasible"
    console.print(f"{complete} trials: best {spec.objective} {best.value:.2f} (trial {best.number}{verdict}): {fields}")




def _bad(what: str) -> int:
    print(f"vil tune: {what}", file=sys.stderr)
    return EXIT_BAD_INPUT
