"""One way to start a run: a scenario and the options `vil run` takes in, a run ready to go out.

    runs = prepare_runs([(scenario, RunOptions(strategy="greedy", loss_frac=0.2))], command, say)
    result = run_prepared(runs[0])

Every front end starts its runs here: `vil run` (its flags parsed into `RunOptions`), `vil.run`
(its keyword arguments), a sweep's cells (the variant and the checks; they write no folder) and
`vil gcs` (the variant and the checks; the console keeps its own folder and resume). What it does,
in order: the variant scenario (`variant`: the fleet drawn from the seed if asked, then strategy,
seed, duration, theta), the checks before anything runs (`check_start`, `check_strategy`), the link's
options (faults, failing aPads, signing: `link_options`), and the folder (`gcs.mission.run_placement`:
a new one keeping the command, or the one to resume, its checkpoint checked), with `latest` pointing
at the last. Bad input is one line: `ScenarioError`, `CheckpointError`, or `OSError` from the folder.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

from acoustic import per
from gcs.link.faultproxy import LinkFaults
from gcs.mission.checkpoint import setup_digest
from gcs.mission.headless import ProgressFn, run_mission
from gcs.mission.platform import DEFAULT_PLATFORM, NO_CHECKPOINT, WIRE, Platform, wire_only_problem
from gcs.mission.run_placement import place
from gcs.mission.world import LinkOptions
from gcs.records.run_folder import RunFolder
from gcs.results.run_result import RunResult
from gcs.scenario.model_params import check_inputs
from gcs.scenario.reader import MAX_DURATION_S, SEED_MAX, THETA_RANGE, Scenario, ScenarioError, out_of_range
from gcs.strategies import is_plugin, load_strategy, source_of
from missiontime.durations import hms

RUNS = Path("runs")  # where runs go unless told
# One-way delay bound: slower than this the GCS never hears the aPad's first heartbeat in time (10 s
# round trips) and the aPad's failsafe (3 s without the GCS) holds it at every gap.
MAX_DELAY_S = 5.0
SYSID_RANGE = (1, 249)  # an aPad's MAVLink system id

Say = Callable[[str], None]  # one line for the user (the front end adds its name)


@dataclass(frozen=True)
class RunOptions:
    """What a run is started with besides its scenario: `vil run`'s flags, one run's worth (None: the
    scenario's own). Out-of-range values are a `ScenarioError` line naming the option."""

    strategy: str | None = None  # a shipped name or a spec to load (FILE.py:FUNCTION, MODULE:FUNCTION, ...)
    seed: int | None = None
    duration_s: float | None = None
    theta: float | None = None
    draw_fleet: bool = False  # the fleet drawn from the seed, not the scenario's saved start configuration
    loss_frac: float = 0.0  # link faults: the aPad link over real UDP through a seeded proxy
    latency_s: float = 0.0
    jitter_s: float = 0.0
    duplicate_frac: float = 0.0
    outages_s: tuple[tuple[float, float], ...] = ()  # (start, end) mission times of total link loss
    fail_apads: tuple[tuple[int, float], ...] = ()  # (system id, mission time) an aPad goes silent for good
    proxy: bool = False  # through the proxy even with no faults
    signing_key: bytes | None = None  # MAVLink 2 signing (the key, sha256 of the passphrase)
    resume: bool = False  # continue the newest folder of this run holding a checkpoint
    out: Path = field(default=RUNS)  # runs go in out/SCENARIO-STRATEGY-seedN-runK
    platform: Platform = DEFAULT_PLATFORM  # lockstep (the reference) or event (gcs.mission.platform)

    def __post_init__(self) -> None:
        problem = _problem(self)
        if problem:
            raise ScenarioError(problem)


def _problem(o: RunOptions) -> str | None:
    """The first option out of its range, as one line, or None (the flags' own bounds)."""
    ranges: list[tuple[str, float | None, float, float]] = [
        ("seed", o.seed, 0, SEED_MAX), ("theta", o.theta, *THETA_RANGE),
        ("duration", o.duration_s, 0, MAX_DURATION_S), ("loss", o.loss_frac, 0, 1),
        ("latency", o.latency_s, 0, MAX_DELAY_S), ("jitter", o.jitter_s, 0, MAX_DELAY_S),
        ("duplicate", o.duplicate_frac, 0, 1),
    ]
    for name, value, lo, hi in ranges:
        why = None if value is None else out_of_range(value, lo, hi)
        if why:
            return f"{name}: {why}"
    if o.duration_s == 0:
        return "duration: must be more than 0 s"
    wire = wire_only_problem(o.platform, wire_options(o))
    if wire:
        return wire
    for name, value in (("loss", o.loss_frac), ("duplicate", o.duplicate_frac)):
        if value >= 1:
            return f"{name}: must be a fraction below 1, got {value:g}"
    for start, end in o.outages_s:
        if out_of_range(start, 0, MAX_DURATION_S) or out_of_range(end, 0, MAX_DURATION_S) or not start < end:
            return f"outage {start:g}:{end:g} s: expected START:END mission times with START before END"
    for sysid, at_s in o.fail_apads:
        if not SYSID_RANGE[0] <= sysid <= SYSID_RANGE[1] or out_of_range(at_s, 0, MAX_DURATION_S):
            return (f"fail-apad {sysid}:{at_s:g} s: expected an aPad system id in {SYSID_RANGE[0]}..{SYSID_RANGE[1]}"
                    " and a mission time")
    return None


def wire_options(o: RunOptions) -> list[tuple[str, str]]:
    """(option, why) for each option given that only lockstep honours, in the order --help lists them."""
    given = [("loss", o.loss_frac > 0), ("latency", o.latency_s > 0), ("jitter", o.jitter_s > 0),
             ("duplicate", o.duplicate_frac > 0), ("outage", bool(o.outages_s)), ("fail-apad", bool(o.fail_apads)),
             ("proxy", o.proxy), ("signing key (--signing-key or $VIL_SIGNING_KEY)", o.signing_key is not None)]
    return [(name, WIRE) for name, asked in given if asked] + ([("resume", NO_CHECKPOINT)] if o.resume else [])


@dataclass(frozen=True)
class PreparedRun:
    """A run ready to go: its scenario as run, its folder, how its link is made, whether it resumes."""

    scenario: Scenario  # the variant: strategy, seed, duration, theta and fleet as asked
    out_dir: Path  # its own folder: new, the one it resumes, or (`finished`) where it ended before
    link: LinkOptions | None = None  # None: the embedded aPad in memory, no faults, unsigned
    resume_from_s: float | None = None  # resuming: the mission time of its checkpoint
    finished: RunResult | None = None  # several resumed at once: this one had ended, its result is kept
    strategy_source: str = ""  # what loads the strategy in another process (one from outside the package)
    platform: Platform = DEFAULT_PLATFORM

    @property
    def resume(self) -> bool:
        return self.resume_from_s is not None


def variant(base: Scenario, options: RunOptions) -> Scenario:
    """`base` as `options` ask: the fleet drawn from the seed (`draw_fleet`), then strategy, seed,
    duration and theta. The one place a saved start configuration is set aside."""
    s = replace(base, fleet=replace(base.fleet, start_config=None)) if options.draw_fleet else base
    return s.with_overrides(strategy=options.strategy, seed=options.seed, duration_s=options.duration_s,
                            theta=options.theta)


def check_start(base: Scenario, options: RunOptions, say: Say | None = None) -> None:
    """What can be checked of `base` before any run, whatever its strategy and seed: its files (area,
    start configuration of the right size, unless the fleet is drawn), the --fail-apad system ids;
    `say` gets what --seed changes over a saved fleet. `ScenarioError` (one line) if unusable."""
    fleet = variant(base, RunOptions(draw_fleet=options.draw_fleet))  # before the check: a saved start
    check_inputs(fleet)  # of another size is not used when the fleet is drawn
    notice = seed_notice(fleet, options.seed, faults=link_faults(options) is not None)
    if notice and say is not None:
        say(notice)
    ids = {a.system_id for a in base.apads}
    for sysid, _ in options.fail_apads:
        if sysid not in ids:
            raise ScenarioError(f"--fail-apad {sysid}: {base.name} has no aPad {sysid} (its aPads: "
                                f"{', '.join(map(str, sorted(ids)))})")


def check_strategy(scenario: Scenario) -> None:
    """A strategy from outside the package plans once on the start: a bad plan is a line now, not an
    event mid-mission (shipped strategies: nothing to do; the suite tests them)."""
    if is_plugin(scenario.mission.collect_strategy):
        check_inputs(scenario)


def seed_notice(scenario: Scenario, seed: int | None, faults: bool) -> str | None:
    """What `--seed` changes when the scenario's fleet comes from its saved start configuration
    (the seed feeds the world's one rng, the swarm's k-means start and the fault proxy), or None."""
    start = scenario.fleet.start_config
    if seed is None or start is None:
        return None
    drift_cm = scenario.fleet.drift_cm
    drawn = [f"the aMussels' random drift (up to {drift_cm:g} cm a step)"] if drift_cm else []
    drawn += ["where the swarm's k-means sharing starts"] if len(scenario.apads) > 1 else []
    drawn += ["the link faults' draws"] if faults else []
    listed = f"{', '.join(drawn[:-1])} and {drawn[-1]}" if len(drawn) > 1 else "".join(drawn)
    what = f"changes only {listed}" if drawn else "changes nothing in this run"
    return (f"{scenario.name}'s fleet is its saved start configuration ({start.name}): --seed {seed} {what}; "
            "add --draw-fleet to draw the fleet from the seed too")


def link_faults(options: RunOptions) -> LinkFaults | None:
    """The fault proxy's settings, or None when the link does not go through it. Its draws take the
    run's seed (0 if none was given)."""
    faults = LinkFaults(options.loss_frac, options.latency_s, options.jitter_s, options.duplicate_frac,
                        seed=options.seed or 0, outages_s=options.outages_s)
    return faults if options.proxy or faults.any else None


def link_options(options: RunOptions) -> LinkOptions | None:
    """How the GCS reaches the embedded aPads; None: in memory, no faults, unsigned (the fast path)."""
    faults = link_faults(options)
    if faults is None and options.signing_key is None and not options.fail_apads:
        return None
    return LinkOptions(faults=faults, signing_key=options.signing_key, fail_apads=options.fail_apads)


def prepare_runs(requests: Sequence[tuple[Scenario, RunOptions]], command: str, say: Say) -> list[PreparedRun]:
    """Each (scenario, options) as a run ready to go, in order: every check first (each scenario's
    once, a strategy from outside once per scenario), then the folders (`placement.place`: `command`,
    without --resume, is kept in each new one), and `latest` pointing at the last."""
    checked: list[Scenario] = []  # by identity: the front end hands each scenario once, to many runs
    planned: set[tuple[int, str]] = set()
    runs = []
    for base, options in requests:
        if not any(base is c for c in checked):
            check_start(base, options, say)
            checked.append(base)
        s = variant(base, options)
        name = s.mission.collect_strategy
        if (id(base), name) not in planned:
            check_strategy(s)
            planned.add((id(base), name))
        runs.append((s, options))
    placed = place([(s, o.out, o.resume, setup_digest(s, link_options(o))) for s, o in runs], command, say)
    prepared = [PreparedRun(s, p.out_dir, link_options(o), p.resume_from_s, p.finished,
                            source_of(s.mission.collect_strategy), o.platform)
                for (s, o), p in zip(runs, placed, strict=True)]
    RunFolder(prepared[-1].out_dir).point_latest()
    for run in prepared:
        if run.resume_from_s is not None:
            say(f"resuming {run.out_dir} from its checkpoint at {hms(run.resume_from_s)} (the mission is "
                "replayed to it, its logs muted)")
    return prepared


def prepare_run(base: Scenario, options: RunOptions, command: str, say: Say) -> PreparedRun:
    """One run ready to go (`prepare_runs` of one)."""
    return prepare_runs([(base, options)], command, say)[0]


def run_prepared(run: PreparedRun, progress: ProgressFn | None = None) -> RunResult:
    """Run it to its end in its folder (a finished one: its kept result). In any process: a strategy
    from outside the package is loaded again here."""
    if run.finished is not None:
        return run.finished
    load_strategy(run.strategy_source or run.scenario.mission.collect_strategy)
    if run.scenario.acoustic.enabled:
        per.load()  # the channel's curve imports scipy.special at first use: here, not in the run's wall time
    return run_mission(run.scenario, run.out_dir, progress=progress, options=run.link, resume=run.resume,
                       platform=run.platform)
