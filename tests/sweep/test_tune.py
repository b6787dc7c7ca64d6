"""`vil tune`: Optuna's trials as real missions on a real Dask cluster, the study kept in SQLite through a
SIGKILL, the best policy as a scenario `vil run` runs, the held-out table, and bad specs in one line."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import optuna
import pandas as pd
import pytest
from sqlalchemy.exc import SQLAlchemyError
from testkit import MISSIONS

from gcs.cli.main import main
from gcs.tune.spec import load_tune_spec
from gcs.tune.study import STUDY_DB, distributions, open_study

REPO = MISSIONS.parent

# pool12 on the event platform: a trial (two seeds) of 10-minute missions takes a fraction of a second; the
# killed study's are 40 minutes, so it is still running when the test has seen two trials end.
SPEC = """
[tune]
name = "tiny"
scenario = "pool12"
strategy = "cautious"
baseline = "greedy"
objective = "uptime_avg"
trials = {trials}
seeds = [1, 2]
held_out = "101-102"
sampler_seed = 7
[set]
mission.duration = "{duration}"
mission.theta = 60
[search]
mission.pool_threshold = {{min = 0.6, max = 0.95}}
mission.min_pool = {{min = 1, max = 4}}
"""
KILL_TIMEOUT_S = 120.0  # the killed run must have finished two trials by then (it takes seconds)


def study_of(out: Path) -> optuna.Study:
    return optuna.load_study(study_name="tiny", storage=f"sqlite:///{out / STUDY_DB}")


def complete(out: Path) -> list[optuna.trial.FrozenTrial]:
    if not (out / STUDY_DB).exists():
        return []
    try:
        return study_of(out).get_trials(states=(optuna.trial.TrialState.COMPLETE,))
    except (KeyError, SQLAlchemyError, optuna.exceptions.StorageInternalError):  # the study is being made
        return []


def test_a_study_killed_with_sigkill_goes_on_where_it_stopped(tmp_path: Path,
                                                               capsys: pytest.CaptureFixture[str]) -> None:
    spec = tmp_path / "tiny.toml"
    spec.write_text(SPEC.format(trials=8, duration="40m"))
    out = tmp_path / "study"
    run = subprocess.Popen([sys.executable, "-m", "gcs.cli.main", "tune", str(spec), "--out", str(out),
                            "--workers", "1", "--no-held-out"], cwd=REPO, stdout=subprocess.DEVNULL,
                           stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        deadline = time.monotonic() + KILL_TIMEOUT_S
        while len(complete(out)) < 2 and run.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        assert run.poll() is None, "the study ended before it could be killed"
        os.killpg(run.pid, signal.SIGKILL)  # the command, its cluster and its workers, mid-trial
        run.wait()
    finally:
        if run.poll() is None:
            os.killpg(run.pid, signal.SIGKILL)
            run.wait()
    before = {t.number: t.value for t in complete(out)}
    left_running = [t.number for t in study_of(out).get_trials(states=(optuna.trial.TrialState.RUNNING,))]
    assert 2 <= len(before) < 8
    best_before = max(before.values())

    assert main(["tune", str(spec), "--out", str(out), "--workers", "2", "--no-held-out"]) == 0
    printed = capsys.readouterr().out
    assert f"tiny: {len(before)} of 8 trials done" in printed  # the count was kept
    after = complete(out)
    assert len(after) == 8
    assert {t.number: t.value for t in after if t.number in before} == before  # every trial kept as it was
    assert max(t.value for t in after) >= best_before
    states = [t.state for t in study_of(out).get_trials()]
    again = [t for t in study_of(out).get_trials() if "again_of" in t.user_attrs]
    # A trial killed while running was failed and its policy asked again, not lost and not counted twice.
    assert states.count(optuna.trial.TrialState.RUNNING) == 0
    assert sorted(t.user_attrs["again_of"] for t in again) == left_running
    for trial in again:
        lost = study_of(out).trials[trial.user_attrs["again_of"]]
        assert lost.state == optuna.trial.TrialState.FAIL and lost.params == trial.params


def test_a_trial_left_running_is_failed_and_its_policy_asked_again_first(tmp_path: Path) -> None:
    spec = load_tune_spec(_spec_file(tmp_path, 3))
    out = tmp_path / "study"
    out.mkdir()
    study = open_study(spec, out)
    study.tell(study.ask(distributions(spec)), 50.0)
    killed = study.ask(distributions(spec))  # what a killed run leaves: RUNNING for ever
    reopened = open_study(spec, out)
    lost = reopened.trials[killed.number]
    assert lost.state == optuna.trial.TrialState.FAIL
    retried = reopened.ask(distributions(spec))
    assert retried.params == killed.params and retried.user_attrs["again_of"] == killed.number
    assert [t.value for t in reopened.get_trials(states=(optuna.trial.TrialState.COMPLETE,))] == [50.0]


def _spec_file(tmp_path: Path, trials: int) -> Path:
    spec = tmp_path / "tiny.toml"
    spec.write_text(SPEC.format(trials=trials, duration="10m"))
    return spec


def shipped_in_short_form(tmp_path: Path) -> Path:
    """missions/tune/cautious-40.toml (docs/tuning.md) as the suite runs it: its scenario, strategy, search
    space and objective; 3 trials of two 10-minute missions, 2 held-out seeds."""
    text = (MISSIONS / "tune/cautious-40.toml").read_text()
    text = (text.replace("trials = 40", "trials = 3").replace('seeds = "1-3"', "seeds = [1, 2]")
            .replace('held_out = "101-120"', 'held_out = "101-102"').replace('"24h"', '"10m"')
            .replace('"bay-capacity"', '"' + str(MISSIONS / "bay-capacity.toml") + '"'))
    spec = tmp_path / "cautious-40.toml"
    spec.write_text(text)
    return spec


def test_the_shipped_example_its_best_policy_as_a_scenario_and_the_held_out_table(
    tmp_path: Path, capsys: pytest.CaptureFixture[str],
) -> None:
    spec = shipped_in_short_form(tmp_path)
    out = tmp_path / "study"
    assert main(["tune", str(spec), "--out", str(out), "--workers", "2"]) == 0
    printed = capsys.readouterr().out
    assert "3 trials: best uptime_min" in printed and "2 held-out seeds (101-102)" in printed
    study = optuna.load_study(study_name="cautious-40", storage=f"sqlite:///{out / STUDY_DB}")
    trials = study.get_trials(states=(optuna.trial.TrialState.COMPLETE,))
    feasible = [t for t in trials if t.user_attrs["depleted"] <= 0] or trials
    best = max(feasible, key=lambda t: (t.value, -t.number))
    assert set(best.params) == {"mission.pool_threshold", "mission.charged_threshold", "mission.min_pool",
                                "fleet.wake_interval_s", "fleet.awake_s"}
    # vil run on best.toml, seed 2 with its fleet drawn (as the study's missions), gives the trial's value.
    assert main(["run", str(out / "best.toml"), "--seed", "2", "--draw-fleet", "--platform", "event",
                 "--json", str(tmp_path / "r.json")]) == 0
    ran = json.loads((tmp_path / "r.json").read_text())
    runs = ran.get("runs", [ran])
    assert runs[0]["strategy"] == "cautious" and runs[0]["uptime"]["min"] == best.user_attrs["per_seed"][1]
    values = pd.read_csv(out / "held_out.csv").set_index("output")[["tuned", "baseline"]]
    assert values.drop(index="missions with an aMussel run flat").notna().all().all()  # sleepers: samples too
    assert (out / "held_out.md").read_text().count("\n") == len(values) + 4
    # Run again: the study is done and every held-out mission is in DIR/cells: nothing runs.
    assert main(["tune", str(spec), "--out", str(out), "--workers", "1"]) == 0
    assert "3 of 3 trials done" in capsys.readouterr().out


@pytest.mark.parametrize(("change", "said"), [
    (("objective = \"uptime_avg\"", "objective = \"joy\""), "tune.objective: 'joy' is not an output"),
    (('held_out = "101-102"', "held_out = [2]"), "tune.held_out: seed 2 is also a tuning seed"),
    (("{min = 0.6, max = 0.95}", "{min = 0.95, max = 0.6}"), "search.mission.pool_threshold: expected {min = A"),
    (("[search]", "[search]\nmission.theta = [30]\n[x]"), "[x]: unknown table"),
    (('scenario = "pool12"', 'scenario = "nowhere"'), "nowhere"),
    (("mission.theta = 60", "mission.theta = -1"), "mission.theta: -1 is outside"),
])
def test_a_bad_tune_spec_is_one_line_and_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                change: tuple[str, str], said: str) -> None:
    spec = tmp_path / "bad.toml"
    spec.write_text(SPEC.format(trials=3, duration="10m").replace(*change))
    assert main(["tune", str(spec), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and said in err, err
    assert not (tmp_path / "out" / STUDY_DB).exists()


def test_a_study_held_by_a_run_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from gcs.tune.study import study_lock

    spec = tmp_path / "tiny.toml"
    spec.write_text(SPEC.format(trials=2, duration="10m"))
    assert load_tune_spec(spec).trials == 2
    with study_lock(tmp_path / "study"):
        assert main(["tune", str(spec), "--out", str(tmp_path / "study"), "--workers", "1"]) == 1
    assert "another vil tune is running this study" in capsys.readouterr().err
