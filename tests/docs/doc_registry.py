"""The registry: every example command of README.md and docs/*.md, keyed by its exact text, with how it
runs and which of its claims is checked.

- `room`: the test file that runs it (test_doc_ROOM.py); `run`: the function that runs it and checks
  its claim (its docstring says what is checked). Several commands that make one story (a SITL aPad and
  what connects to it, a sweep and its report) share one run, and so one test.
- `ci`: the line the default run uses when it is not the command as written, and `why`. A placeholder
  (NAME, SPEC.toml, DIR, HOST, runs/A) is always filled in by the `ci` line.
- `full`: in a run under the `long` marker (`make test-long`, `pytest -m long tests/docs`), the command as written runs
  instead of its `ci` line (True), or the line given, or nothing (False: the `ci` line is the example).
- `long_only`: why its run is left out of the default run (the suite's CPU budget: about 60 s for the
  doc examples) and runs only under the `long` marker, and which default test covers the same path.

test_doc_coverage.py holds the table to the docs: every example has an entry, every entry an example.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import doc_consoles as con
import doc_links as lnk
import doc_runs as run
import doc_sweeps as swp
import doc_tools as tls
from doc_harness import Work

Room = Literal["runs", "consoles", "links", "sweeps", "tools"]


@dataclass(frozen=True)
class Entry:
    room: Room
    run: Callable[[Work], None]
    ci: str = ""
    why: str = ""
    full: bool | str = True
    long_only: str = ""  # why it runs only under the long marker (its ci line, or as written): CPU, covered where

    def line(self, command: str, full: bool) -> str:
        """The line to run for `command` in a default run (`full` False) or a long one."""
        if not full or self.full is False:
            return self.ci or command
        return self.full if isinstance(self.full, str) else command


SWEEP_LONG = ("a local Dask cluster, its missions and the report: 7-15 s of CPU a sweep; `vil sweep` with its report "
              "and --keep-runs are tests/sweep/test_sweep_run.py's, the shipped spec test_doc_sweeps.py's, in the "
              "default run")
CLUSTER_LONG = ("a scheduler, a worker and a client start for 8 s of CPU; `dask scheduler`, `dask worker` and "
                "`vil sweep --scheduler` are tests/sweep/test_sweep_cluster.py's too, in the default run")
CAPACITY_LONG = ("a local Dask cluster and four missions (8-15 s of CPU); the same path, a tiny capacity sweep, "
                 "its table and figure, is tests/sweep/test_capacity_sweep.py's in the default run")
SENSITIVITY_LONG = ("a local Dask cluster and 36 missions (10 s of CPU); the shipped study's short form, its report "
                    "and Ishigami through the same path are tests/sweep/test_sensitivity.py's, in the default run")
TUNE_LONG = ("a local Dask cluster and its trials (8-12 s of CPU); a study of real missions, its SIGKILL and resume, "
             "best.toml run by vil run and the held-out table are tests/sweep/test_tune.py's, in the default run")
ACOUSTIC_LONG = ("a local Dask cluster and its missions (8-12 s of CPU); the spec's cells run and the table is "
                 "made from them in tests/sweep/test_acoustic_compare.py, in the default run")
MODEM_LONG = ("two processes on the wall clock for a minute; the same path (vil modem --sea as a process, the "
              "console's GCS on its pty) is tests/tui/test_gcs_modem.py's, in the default run")
DEV_MAKE = "`-o .venv/.installed`: a test never rebuilds the shared venv (it is rebuilt when pyproject.toml changes)"

REGISTRY: dict[str, Entry] = {
    # README: Quick start
    tls.MAKE_RUN: Entry("tools", tls.run_make_run, ci="make -n -o .venv/.installed run",
                        full="make -o .venv/.installed run",
                        why="Table II is 4 x 40 mission minutes, 17 s of CPU: the dry run shows `vil run` is what runs "
                            "(and, in a folder without .venv, that it is created first); " + DEV_MAKE),
    tls.MAKE_TEST: Entry("tools", tls.run_make_test, ci="make -n -o .venv/.installed test",
                         full="make -o .venv/.installed test",
                         why="the whole suite cannot run inside itself: the dry run shows ruff, mypy and pytest; "
                             "the long run runs it (the long tests left out, as `make test` leaves them); " + DEV_MAKE),
    # README: Examples
    run.SEED3: Entry("runs", run.run_seed3, ci=run.SEED3 + " --duration 7m",
                     why="the claim needs a second run (seed 1): two 40-minute missions are 8 s of CPU; 7 minutes "
                         "tell the fleets apart (at 5 both are still at 100 %: nobody collected, nobody depleted)"),
    run.SEEDS20: Entry("runs", run.run_seeds20, ci="vil run --seeds 2 --duration 2m",
                       why="120 missions of 40 minutes are 7 minutes of CPU; 2 drawn fleets of 2 minutes keep the "
                           "shape (both scenarios, the three strategies, n per row)"),
    lnk.SITL: Entry("links", lnk.run_sitl_listing1,
                    ci=lnk.SITL + " --param DOCK_TIME=1 --param SPEED_MAX=2.0 --param ACCEL_MAX=1.0",
                    why="the dock's 10 s of latching and the sail at 0.5 m/s are idle wall time; a brisk aPad "
                        "(tests/sitl/test_listing1.py's) with a 1-s latch sails and docks the same way"),
    lnk.LISTING1: Entry("links", lnk.run_sitl_listing1, ci=lnk.LISTING1 + " --distance 2",
                        why="aMussel 24 rests 10 m away, 20 s of sailing at 0.5 m/s (31 s of wall time, idle); 2 m "
                            "is the same listing in 9 s"),
    con.GCS_SITL: Entry("consoles", con.run_gcs_sitl),
    con.WEB: Entry("consoles", con.run_web),
    con.WEB_ALL: Entry("consoles", con.run_web_all),
    con.REPLAY: Entry("consoles", con.run_replay),
    tls.REPORT_LATEST: Entry("tools", tls.run_report_latest),
    tls.REPORT_AB: Entry("tools", tls.run_report_ab, full=False,
                         ci="vil report runs/pool12-greedy-seed1-run1 runs/pool12-cautious-seed1-run1 -o compare/",
                         why="A, B: the two recorded runs",
                         long_only="two reports and their comparison, 6 s of CPU; the comparison page is "
                                   "tests/tui/test_report.py's, in the default run"),
    swp.QUICK_SWEEP: Entry("sweeps", swp.run_quick_sweep,
                           long_only="a local Dask cluster and 15 missions of 40 minutes (30 s of CPU); the spec's "
                                     "shape is tests/sweep/test_spec.py's, a sweep on a cluster "
                                     "tests/sweep/test_sweep_run.py's, in the default run"),
    swp.STRATEGIES_SWEEP: Entry("sweeps", swp.run_strategies_sweep, long_only=SWEEP_LONG),
    # README: Stock MAVLink tools
    lnk.MAVPROXY: Entry("links", lnk.run_mavproxy),
    lnk.MAVLOGDUMP: Entry("links", lnk.run_mavlogdump),
    # README: A swarm
    run.POOL12X2: Entry("runs", run.run_pool12x2, ci=run.POOL12X2 + " --duration 2m",
                        why="the shares and a loop per aPad are there from the start: 2 of the 40 minutes"),
    run.BAY120: Entry("runs", run.run_bay120, ci="vil run bay120 --fail-apad 3:60s --duration 2m",
                      why="bay120 costs 0.4 s of CPU a mission minute (40: 10 s; 11, to pass 600 s: 5 s): aPad 3 "
                          "fails at 60 s of a 2-minute mission, is lost and its share re-shared the same way"),
    lnk.SITL_X2: Entry("links", lnk.run_sitl_x2_and_gcs),
    lnk.GCS_CONNECT: Entry("links", lnk.run_sitl_x2_and_gcs),
    con.GCS_X2: Entry("consoles", con.run_gcs_x2),
    # README: Faults, signing, crash and resume
    run.LOSS: Entry("runs", run.run_loss, ci=run.LOSS + " --duration 5m",
                    why="the proxy's drops, delays and duplicates in both directions show within 5 minutes"),
    run.OUTAGE: Entry("runs", run.run_outage, ci=run.OUTAGE + " --duration 7m",
                      why="the hold at 94.5 s and the resumed Go To at 112 s, then the collection going on: 7 minutes "
                          "(not fewer: nobody is called up in a mission's last 5 minutes)"),
    run.SIGNING: Entry("runs", run.run_signing, ci=run.SIGNING + " --duration 2m",
                       why="every frame signed shows in 2 minutes as in 40"),
    run.RESUME: Entry("runs", run.run_resume, ci=run.RESUME + " --duration 5m",
                      why="the run killed first is `vil run pool12 --duration 5m` (SIGKILL past its checkpoint at "
                          "120 s), and the resume takes the flags it was started with; the long run kills the "
                          "40-minute pool12 and pool12x2 and resumes them as written"),
    con.GCS_RESUME: Entry("consoles", con.run_gcs_resume,
                          long_only="two consoles and minutes of mission at 100x, 7 s of CPU; a console killed with "
                                    "aMussels docked and resumed is tests/robust/test_console_crash_resume.py's, in "
                                    "the default run"),
    # README: Benchmarks
    tls.MAKE_BENCH: Entry("tools", tls.run_make_bench, ci="make -n -o .venv/.installed bench",
                          full="make -o .venv/.installed bench",
                          why="every benchmark at full size takes minutes: the dry run shows what runs, and each "
                              "of the eight below runs on its own; " + DEV_MAKE),
    tls.THROUGHPUT: Entry("tools", tls.run_throughput, ci=tls.THROUGHPUT + " --count 2000",
                          why="50,000 messages per figure take 10 s; 2,000 print the same tables"),
    tls.FLEET_STEP: Entry("tools", tls.run_fleet_step),
    tls.SCENARIO_SPEED: Entry("tools", tls.run_scenario_speed,
                              ci=tls.SCENARIO_SPEED + " --scenarios pool12-2m.toml --repeat 1",
                              why="four 40-minute missions, each timed 3 times and once more instrumented, are a "
                                  "minute of CPU: pool12 of 2 minutes (a copy of pool12.toml), timed once"),
    tls.TUI_FRAME: Entry("tools", tls.run_tui_frame,
                         long_only="6 s of CPU, and no flag makes it smaller; drawing the console is tests/tui's"),
    tls.LONG_MISSION: Entry("tools", tls.run_long_mission, ci=tls.LONG_MISSION + " --short 1 --long 6",
                            why="a 4-hour mission is 20 s of CPU: 6 minutes against 1, the same ratio of 6"),
    tls.MISSION_COST: Entry("tools", tls.run_mission_cost, ci=tls.MISSION_COST + " --only pool12 --day-h 1",
                            why="three days of missions are twenty minutes of CPU: pool12's hour against its 40 "
                                "minutes prints the same lines"),
    tls.QUIET_FLOOR: Entry("tools", tls.run_quiet_floor,
                           ci=tls.QUIET_FLOOR + " --short-h 0.05 --day-h 0.05 --hours 0.05 --repeat 1",
                           why="seven runs twice, one of them bay120-sleep's day, are five minutes of CPU: 3 minutes "
                               "each (bay120's 40 minutes too), once, print the same rows"),
    tls.PLATFORMS: Entry("tools", tls.run_platforms,
                         ci=tls.PLATFORMS + " --part agreement --seeds 1 --scenarios pool12 --strategies greedy "
                                               "--jobs 1",
                         why="every scenario and strategy on 20 seeds, the days and the year are an hour of CPU: one "
                             "seed of pool12 greedy on both platforms prints the agreement table's row (in one "
                             "worker process: a second one's start costs more than it saves for two missions)"),
    tls.STARTUP: Entry("tools", tls.run_startup, ci=tls.STARTUP + " --repeat 1",
                       why="best of 5 fresh processes each; one shows the same rows"),
    # README: Long missions
    run.SLEEP_DAY: Entry("runs", run.run_sleep_day, ci="vil run missions/bay120-sleep.toml --duration 6m",
                         why="the day is 5 minutes of CPU: 6 minutes show the flag over the file's 40 and a fleet "
                             "asleep (the long run runs the day and checks every aMussel alive at its end)"),
    run.EVENT_DAY: Entry("runs", run.run_event_day, ci="vil run bay120-sleep --duration 1h --platform event",
                         why="two of the day's hours show the platform named, no .tlog and the fleet alive; the long "
                             "run runs the day"),
    # README: A scenario of your own
    run.COPY: Entry("runs", run.run_own_scenario),
    run.SED: Entry("runs", run.run_own_scenario),
    run.MINE: Entry("runs", run.run_own_scenario, ci=run.MINE + " --duration 5m",
                    why="the copy's paths and its run are what is checked: 5 of the 40 minutes (4.5 s of CPU less)"),
    # README and docs/strategies.md: A strategy of your own
    run.SLACK_RUN: Entry("runs", run.run_slack_first, ci=run.SLACK_RUN + " --duration 6m",
                         why="the strategy plans its first collection at 0.05 s; 6 minutes, as nobody is called up "
                             "in a mission's last 5"),
    swp.SLACK_SWEEP: Entry("sweeps", swp.run_slack_sweep,
                           long_only="20 missions of 40 minutes on a local cluster (20 s of CPU); the plugin in a "
                                     "sweep is tests/plugins' (default run); the long run checks the doc's table"),
    # docs/strategies.md: Measured
    run.POOL12_NAME: Entry("runs", run.run_pool12_name, ci="vil run pool12 --strategy lookahead --seeds 2 "
                                                              "--json pool12-lookahead.json --duration 2m",
                           why="NAME: lookahead; 8 strategies x 20 fleets x 40 minutes are 8 minutes of CPU: the long "
                               "run checks the Measured table's figures against all of them"),
    run.BAY24_NAME: Entry("runs", run.run_bay24_name,
                          ci="vil run bay24 --strategy lookahead --seeds 2 --json bay24-lookahead.json --duration 2m",
                          why="as pool12's"),
    # docs/sweeps.md
    swp.STRATEGIES_SEEDS2: Entry("sweeps", swp.run_strategies_sweep,
                                 long_only=SWEEP_LONG + "; --seeds N against the whole spec is "
                                           "tests/sweep/test_sweep_run.py's"),
    swp.KEEP_RUNS: Entry("sweeps", swp.run_keep_runs, full=False, ci=f"vil sweep {swp.ONE_SPEC} --out kept --keep-runs",
                         why="SPEC.toml: one 2-minute mission; DIR: kept", long_only=SWEEP_LONG),
    swp.REPORT: Entry("sweeps", swp.run_strategies_sweep, ci="vil sweep report sweeps/strategies", full=False,
                      why="DIR: the shipped spec's sweep above", long_only=SWEEP_LONG),
    swp.ON_CLUSTER: Entry("sweeps", swp.run_cluster, full=False,
                          ci=f"vil sweep {swp.ONE_SPEC} --out one --scheduler tcp://127.0.0.1:8786 --no-report",
                          why="SPEC.toml: one 2-minute mission, DIR: one, HOST: this machine; --no-report: the "
                              "report is `vil sweep report DIR`'s, checked on the local sweep",
                          long_only=CLUSTER_LONG),
    swp.SCHEDULER: Entry("sweeps", swp.run_cluster, full=False, ci=swp.SCHEDULER + " --host 127.0.0.1",
                         why="a test opens no Dask scheduler (it runs the code it is sent) to every network",
                         long_only=CLUSTER_LONG),
    swp.WORKER: Entry("sweeps", swp.run_cluster, full=False, ci="dask worker tcp://127.0.0.1:8786 --nthreads 1",
                      why="HOST: this machine", long_only=CLUSTER_LONG),
    # docs/capacity.md
    swp.CAPACITY_SWEEP: Entry("sweeps", swp.run_capacity, full=False,
                              ci=f"vil sweep {swp.CAPACITY_TINY} --out capacity-tiny --workers 1",
                              why="520 missions of 24 h are half an hour on 2 cores: the same shape, the smallest "
                                  "size per profile, one seed, 3 minutes each", long_only=CAPACITY_LONG),
    swp.CAPACITY_REPORT: Entry("sweeps", swp.run_capacity, full=False,
                               ci="python -m gcs.sweep.capacity capacity-tiny --figure capacity.png",
                               why="DIR: the tiny sweep above; the figure written beside it, not over the doc's",
                               long_only=CAPACITY_LONG),
    swp.CAPACITY_LOCKSTEP: Entry("sweeps", swp.run_capacity, full=False,
                                 ci=f"vil sweep {swp.CAPACITY_LOCKSTEP_TINY} --out capacity-lockstep-tiny --workers 1",
                                 why="24-h lockstep missions are minutes each: the same shape in short form",
                                 long_only=CAPACITY_LONG),
    swp.CAPACITY_AGREE: Entry("sweeps", swp.run_capacity, full=False,
                              ci="python -m gcs.sweep.capacity capacity-tiny --against capacity-lockstep-tiny",
                              why="the two tiny sweeps above", long_only=CAPACITY_LONG),
    # docs/sensitivity.md
    swp.SENSITIVITY_SWEEP: Entry("sweeps", swp.run_sensitivity, full=False,
                                 ci=f"vil sweep {swp.SENSITIVITY_TINY} --out sensitivity-tiny --workers 1",
                                 why="4,608 missions of 6 h are an hour and more on 2 cores: the same fields, bounds "
                                     "and outputs, n = 2 (36 missions) of 3 minutes", long_only=SENSITIVITY_LONG),
    swp.SENSITIVITY_FIRST: Entry("sweeps", swp.run_sensitivity, full=False,
                                 ci=f"vil sweep {swp.SENSITIVITY_TINY} --out sensitivity-tiny --workers 1 "
                                    "--base-samples 1",
                                 why="the tiny study's first base sample, then the whole tiny study keeps it",
                                 long_only=SENSITIVITY_LONG),
    swp.SENSITIVITY_REPORT: Entry("sweeps", swp.run_sensitivity, full=False,
                                  ci="vil sweep report sensitivity-tiny", why="DIR: the tiny study above",
                                  long_only=SENSITIVITY_LONG),
    # docs/tuning.md
    swp.TUNE: Entry("sweeps", swp.run_tuning, full=False,
                    ci=f"vil tune {swp.TUNE_TINY} --out tune/cautious-40 --workers 1",
                    why="40 trials of three 24-h missions and 40 held-out ones are 15 minutes on 2 cores: 3 trials of "
                        "one 10-minute mission, 2 held-out seeds", long_only=TUNE_LONG),
    swp.TUNE_RUN: Entry("sweeps", swp.run_tuning, full=False,
                        ci="vil run tune/cautious-40/best.toml --duration 10m --platform event",
                        why="the tiny study's best policy, for as long as its missions", long_only=TUNE_LONG),
    # docs/acoustic.md
    run.ACOUSTIC_FIGURES: Entry("runs", run.run_acoustic_figures, full=False,
                                ci="python docs/acoustic_figures.py --figure acoustic-delivery.png",
                                why="the figure written beside the run, not over the doc's (the command as written "
                                    "made docs/acoustic-delivery.png)"),
    run.VIL_MODEM: Entry("runs", run.run_vil_modem, ci=run.VIL_MODEM + " --ping-timeout 1s",
                         why="the unit's own 4 s is tests/acoustic/test_modem_pty.py's; 1 s gives the same #TO "
                             "(unit 5's answer is back in 0.61 s)"),
    run.FUZZ_MODEM: Entry("runs", run.run_fuzz_modem, ci=run.FUZZ_MODEM + " -n 2000",
                          why="120,000 inputs are minutes of CPU; 2,000 print the same counts by reason"),
    run.ACOUSTIC_POOL: Entry("runs", run.run_acoustic_pool, ci=run.ACOUSTIC_POOL + " --duration 10m",
                             why="40 mission minutes are 10 s of CPU; 10 print the same line (the doc's figures "
                                 "are the long run's)"),
    run.ACOUSTIC_BAY: Entry("runs", run.run_acoustic_bay, long_only="8 s of CPU; the same path is pool12-acoustic's "
                            "in the default run, and bay24's channel tests/acoustic/test_acoustic_mission.py's"),
    run.ACOUSTIC_BAY120: Entry("runs", run.run_acoustic_bay120,
                               long_only="25-40 s of CPU; the same path (several aPads on the one unit, shares as "
                                         "heard) is tests/acoustic/test_acoustic_mission.py's pool12x2 runs and "
                                         "test_uplink_shared.py's, in the default run"),
    run.ACOUSTIC_KEEP_ALIVE[0]: Entry("runs", run.run_acoustic_keep_alive,
                                      ci="vil run missions/pool12-acoustic.toml --strategy keep_alive --seeds 1 "
                                         "--duration 30m",
                                      why="40 missions are 5 min of CPU; seed 1's first 30 minutes hold the sleep "
                                          "orders and wakes whose belief was 1-5 % off before"),
    run.ACOUSTIC_KEEP_ALIVE[1]: Entry("runs", run.run_acoustic_keep_alive,
                                      ci="vil run missions/bay24-acoustic.toml --strategy keep_alive --seeds 1 "
                                         "--duration 10m",
                                      why="the same on the bay's frame, 10 minutes of seed 1"),
    swp.ACOUSTIC_SWEEP: Entry("sweeps", swp.run_acoustic_sweep, full=False,
                              ci=f"vil sweep {swp.ACOUSTIC_TINY} --out acoustic-tiny --workers 1",
                              why="720 missions (45 min on 2 cores): the spec's grid on pool12, one strategy and "
                                  "seed, 5-minute missions", long_only=ACOUSTIC_LONG),
    swp.ACOUSTIC_COMPARE: Entry("sweeps", swp.run_acoustic_sweep, full=False,
                                ci="python -m gcs.sweep.acoustic_compare acoustic-tiny",
                                why="DIR: the tiny sweep above", long_only=ACOUSTIC_LONG),
    con.MODEM_SEA: Entry("consoles", con.run_gcs_modem, long_only=MODEM_LONG),
    con.GCS_MODEM: Entry("consoles", con.run_gcs_modem, long_only=MODEM_LONG),
}


def runs_of(room: Room, full: bool = False) -> list[Callable[[Work], None]]:
    """The runs of a room, each once, in the registry's order: those of the default run, or (`full`)
    those of the long run: a run with an entry whose long run differs from its ci line, or long only."""
    found: list[Callable[[Work], None]] = []
    for entry in REGISTRY.values():
        if entry.room == room and entry.run not in found:
            found.append(entry.run)

    def entries(r: Callable[[Work], None]) -> list[Entry]:
        return [e for e in REGISTRY.values() if e.run is r]

    if full:
        return [r for r in found if any((e.ci and e.full) or e.long_only for e in entries(r))]
    return [r for r in found if not any(e.long_only for e in entries(r))]


def commands_of(run_function: Callable[[Work], None]) -> list[str]:
    return [command for command, entry in REGISTRY.items() if entry.run is run_function]
