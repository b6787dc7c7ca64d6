"""A `vil tune` study: Optuna's trials as missions on the sweep's Dask cluster, kept where a killed run resumes.

Each trial is a policy (the searched fields' values, `gcs.tune.spec`) run on every tuning seed; its value is
its objective's mean over them, and with `no_depleted` a trial in which any aMussel ran flat is infeasible
(Optuna's constraints: TPE learns from it, the best trial is never one). As many trials run at once as the
cluster has workers (Optuna's ask-and-tell); each mission is a sweep cell, written to DIR/cells as it
finishes, so a mission is never run twice.

The study lives in DIR/study.db (SQLite, Optuna's RDB storage). A run killed at any moment (Ctrl-C, SIGKILL, a
crash) leaves its running trials RUNNING there: the next run fails them and asks their policies again first
(their finished missions are found in DIR/cells), so the complete trials and the best value are kept. One run
at a time holds a study (DIR/study.lock); a second is refused in one line.
"""

from __future__ import annotations

import fcntl
import math
import os
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import optuna
from distributed import Client, Future, as_completed
from optuna.distributions import BaseDistribution, CategoricalDistribution, FloatDistribution, IntDistribution
from optuna.trial import FrozenTrial, Trial, TrialState
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from gcs.sweep import store
from gcs.sweep.cells import Cell, make_cells, run_cell
from gcs.sweep.cluster import CellRunner, describe, run_cells
from gcs.sweep.outputs import output_values, ran_flat
from gcs.sweep.spec import SpecError, Value
from gcs.tune.spec import TuneSpec

STUDY_DB, LOCK = "study.db", "study.lock"
MAX_INVALID = 100  # policies in a row the scenario refuses (e.g. awake >= interval): the search space is wrong
MAX_FAILED = 3  # trials whose missions raised: no new trial is asked after this many (a bug, not bad luck)


class StudyError(RuntimeError):
    """One line: the study cannot go on (held by another run, its space refused, a mission failing)."""


@dataclass(frozen=True)
class Best:
    number: int
    value: float
    params: dict[str, Value]
    depleted: float  # aMussels run flat in its worst tuning mission
    feasible: bool


@dataclass
class TuneOutcome:
    complete: int = 0  # complete trials in the study now
    ran: int = 0  # missions run by this call
    reused: int = 0  # missions found in DIR/cells
    failed: list[str] = field(default_factory=list)  # failed trials: a mission raised, or no objective value
    best: Best | None = None


def distributions(spec: TuneSpec) -> dict[str, BaseDistribution]:
    out: dict[str, BaseDistribution] = {}
    for name, r in spec.search.items():
        if r.choices:
            out[name] = CategoricalDistribution(list(r.choices))
        elif r.integer:
            out[name] = IntDistribution(int(r.low), int(r.high))
        else:
            out[name] = FloatDistribution(r.low, r.high)
    return out


def _constraint(trial: FrozenTrial) -> tuple[float]:
    """Optuna's constraint: feasible at <= 0 (aMussels run flat in the trial's worst mission)."""
    return (float(trial.user_attrs.get("depleted", 1.0)),)


@contextmanager
def study_lock(out: Path) -> Iterator[None]:
    """Held while a run drives the study in `out` (released by the OS when the process dies, SIGKILL too)."""
    out.mkdir(parents=True, exist_ok=True)
    fd = os.open(out / LOCK, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise StudyError(f"{out}: another vil tune is running this study") from None
        yield
    finally:
        os.close(fd)


def open_study(spec: TuneSpec, out: Path) -> optuna.Study:
    """The study in `out` (made on first use), its interrupted trials failed and their policies queued again."""
    optuna.logging.set_verbosity(optuna.logging.WARNING)  # our progress line says what a trial's log would
    study = optuna.create_study(study_name=spec.name, storage=f"sqlite:///{out / STUDY_DB}",
                                direction=spec.direction, load_if_exists=True)
    for trial in study.get_trials(deepcopy=False, states=(TrialState.RUNNING,)):
        study.enqueue_trial(trial.params, user_attrs={"again_of": trial.number})
        study.tell(trial.number, state=TrialState.FAIL)
    # Seeded by the trials so far: a resumed study does not draw its first random policies again. Several
    # trials run at once: each asked while others run assumes their worst (the constant liar), and the fields
    # are drawn together (multivariate: the thresholds, the interval and the awake time go in pairs). Optuna
    # calls these and constraints experimental (since 3.0, unchanged): said once in docs/tuning.md.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
        study.sampler = optuna.samplers.TPESampler(seed=spec.sampler_seed + len(study.trials), multivariate=True,
                                                   constant_liar=True,
                                                   constraints_func=_constraint if spec.no_depleted else None)
    return study


def count_complete(spec: TuneSpec, out: Path) -> int:
    """Complete trials of the study in `out`, its trials left as they are (0: none there yet)."""
    if not (out / STUDY_DB).exists():
        return 0
    try:
        return len(complete_trials(optuna.load_study(study_name=spec.name, storage=f"sqlite:///{out / STUDY_DB}")))
    except KeyError:  # no such study yet
        return 0


def complete_trials(study: optuna.Study) -> list[FrozenTrial]:
    return study.get_trials(deepcopy=False, states=(TrialState.COMPLETE,))


def best_trial(study: optuna.Study, no_depleted: bool = True) -> Best | None:
    """The best complete trial (ties: the earliest); with `no_depleted`, a feasible one if any."""
    trials = complete_trials(study)
    if not trials:
        return None
    feasible = [t for t in trials if _constraint(t)[0] <= 0] if no_depleted else trials
    pool = feasible or trials
    sign = 1.0 if study.direction == optuna.study.StudyDirection.MAXIMIZE else -1.0
    top = max(pool, key=lambda t: (sign * (t.value if t.value is not None else -math.inf), -t.number))
    return Best(top.number, float(top.value or 0.0), dict(top.params), _constraint(top)[0], bool(feasible))


@dataclass
class _Running:
    trial: Trial
    cells: list[Cell]
    results: dict[str, dict[str, Any]] = field(default_factory=dict)  # cell key -> result.json's dict


def run_study(spec: TuneSpec, out: Path, console: Console, client: Client, runner: CellRunner = run_cell
              ) -> TuneOutcome:
    """Run trials on `client`'s cluster until the study in `out` holds `spec.trials` complete ones (see the
    module's docstring); the caller holds `study_lock(out)`."""
    outcome = TuneOutcome()
    study = open_study(spec, out)
    outcome.complete = len(complete_trials(study))
    console.print(f"{spec.name}: {outcome.complete} of {spec.trials} trials done; on {describe(client)}")
    if outcome.complete < spec.trials:
        _drive(spec, out, study, distributions(spec), client, console, outcome, runner)
    outcome.best = best_trial(study, spec.no_depleted)
    return outcome


def run_missions(cells: list[Cell], out: Path, console: Console, client: Client, runner: CellRunner = run_cell
                 ) -> dict[str, dict[str, Any]]:
    """Each cell's result.json (run on the cluster unless DIR/cells has it); StudyError if one raised."""
    done = store.finished(out)
    todo = list({c.key: c for c in cells if c.key not in done}.values())
    if todo:
        ran = run_cells(client, todo, None, lambda cell, record: store.write_cell(out, cell, record), console, runner)
        if ran.failed:
            raise StudyError(f"{len(ran.failed)} missions failed, the first: {ran.failed[0].cell.label}: "
                             f"{ran.failed[0].why}")
    return {c.key: store.read_cell(out, c.key)["result"] for c in cells}


def _drive(spec: TuneSpec, out: Path, study: optuna.Study, space: dict[str, BaseDistribution], client: Client,
           console: Console, outcome: TuneOutcome, runner: CellRunner) -> None:
    slots = max(len(client.scheduler_info(n_workers=-1)["workers"]), 1)
    running: dict[int, _Running] = {}
    owner: dict[Future, tuple[int, Cell]] = {}
    pending = as_completed()
    invalid = 0
    columns = (TextColumn("[progress.description]{task.description}"), BarColumn(), MofNCompleteColumn(),
               TextColumn("trials  best {task.fields[best]}"), TimeElapsedColumn())
    with Progress(*columns, console=console) as progress:
        task = progress.add_task("tune", total=spec.trials, completed=outcome.complete, best=_best_text(study, spec))

        def asking() -> bool:
            return outcome.complete + len(running) < spec.trials and len(outcome.failed) < MAX_FAILED

        while asking() or running:
            while asking() and len(running) < slots:
                trial = study.ask(space)
                point = {k: _plain(v) for k, v in trial.params.items()}
                try:
                    cells = make_cells(spec.sweep(point, spec.seeds))
                except SpecError as exc:  # the scenario refuses this policy: no mission, a failed trial
                    trial.set_user_attr("refused", str(exc).rsplit(": ", 1)[-1])
                    study.tell(trial, state=TrialState.FAIL)
                    invalid += 1
                    if invalid >= MAX_INVALID:
                        raise StudyError(f"{MAX_INVALID} policies in a row refused by the scenario, the last: "
                                         f"{exc}") from None
                    continue
                invalid = 0
                job = running[trial.number] = _Running(trial, cells)
                done = store.finished(out)
                for cell in cells:
                    if cell.key in done:
                        job.results[cell.key] = store.read_cell(out, cell.key)["result"]
                        outcome.reused += 1
                    else:
                        # Keyed by the trial too: two trials asking the same policy at once each get their own.
                        future = client.submit(runner, cell, None, key=f"vil-tune-{trial.number}-{cell.key}",
                                               retries=0, pure=False)
                        owner[future] = (trial.number, cell)
                        pending.add(future)
                if len(job.results) == len(cells):
                    _finish(study, running.pop(trial.number), spec, outcome)
            if not running:
                continue
            future = next(pending)
            number, cell = owner.pop(future)
            job_or_none = running.get(number)
            if future.status == "error":
                raised = future.exception()
                outcome.failed.append(f"trial {number}, {cell.label}: {type(raised).__name__}: {raised}")
                if job_or_none is not None:
                    study.tell(running.pop(number).trial, state=TrialState.FAIL)
            else:  # kept even if its trial failed meanwhile: a mission is never run twice
                record = future.result()
                store.write_cell(out, cell, record)
                outcome.ran += 1
                if job_or_none is not None:
                    job_or_none.results[cell.key] = record["result"]
                    if len(job_or_none.results) == len(job_or_none.cells):
                        _finish(study, running.pop(number), spec, outcome)
            future.release()
            progress.update(task, completed=outcome.complete, best=_best_text(study, spec))


def _finish(study: optuna.Study, job: _Running, spec: TuneSpec, outcome: TuneOutcome) -> None:
    """A trial whose missions all ended: its value (the objective's mean over the seeds) and its constraint. An
    objective with no value (NaN: samples of a fleet that schedules none) fails the trial, said in its attrs."""
    results = [job.results[c.key] for c in job.cells]  # in the seeds' order
    per_seed = [output_values(r)[spec.objective] for r in results]
    job.trial.set_user_attr("depleted", float(max(ran_flat(r) for r in results)))
    job.trial.set_user_attr("per_seed", per_seed)
    value = float(np.mean(per_seed))
    if not math.isfinite(value):
        job.trial.set_user_attr("why", f"{spec.objective} has no value in these missions")
        study.tell(job.trial, state=TrialState.FAIL)
        outcome.failed.append(f"trial {job.trial.number}: {spec.objective} has no value in its missions")
        return
    study.tell(job.trial, value)
    outcome.complete += 1


def _best_text(study: optuna.Study, spec: TuneSpec) -> str:
    best = best_trial(study, spec.no_depleted)
    if best is None:
        return "-"
    return f"{best.value:.2f} (trial {best.number}{'' if best.feasible else ', none feasible yet'})"


def _plain(value: Any) -> Value:
    """An Optuna parameter as a TOML value (numpy scalars from a categorical's choices included)."""
    return value.item() if isinstance(value, np.generic) else value
