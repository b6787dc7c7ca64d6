"""How the make targets, the benchmarks and `vil report` examples run and what of their claims is checked
(the registry's "tools" room).

`make` is never let near the shared venv: a make target's first use is checked as a dry run (`make -n`
in a folder without .venv: it would create it, then run the target), and the target itself runs with
`-o .venv/.installed` (the venv as it is, even where pyproject.toml is newer than its stamp)."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

from doc_harness import ROOT, Work, words

MAKE_RUN = "make run"
MAKE_TEST = "make test"
MAKE_BENCH = "make bench"
THROUGHPUT = ".venv/bin/python bench/mavlink_throughput.py"
FLEET_STEP = ".venv/bin/python bench/fleet_step.py"
SCENARIO_SPEED = ".venv/bin/python bench/scenario_speed.py"
TUI_FRAME = ".venv/bin/python bench/tui_frame.py"
LONG_MISSION = ".venv/bin/python bench/long_mission.py"
PLATFORMS = ".venv/bin/python bench/platforms.py"
MISSION_COST = ".venv/bin/python bench/mission_cost.py"
QUIET_FLOOR = ".venv/bin/python bench/quiet_floor.py"
STARTUP = ".venv/bin/python bench/startup.py"
REPORT_LATEST = "vil report runs/latest"
REPORT_AB = "vil report runs/A runs/B -o compare/"


def first_use(w: Work, target: str) -> list[str]:
    """What `make TARGET` does where there is no .venv yet: the dry run's lines."""
    fresh = w.path / "fresh"
    fresh.mkdir(exist_ok=True)
    for name in ("Makefile", "pyproject.toml", "requirements.lock"):
        if not (fresh / name).exists():
            (fresh / name).symlink_to(ROOT / name)
    lines = w.sh(f"make -n --no-print-directory -C {fresh} {target}").stdout.splitlines()
    made = next(i for i, line in enumerate(lines) if "-m venv .venv" in line)
    assert any("pip install" in line and "-c requirements.lock" in line for line in lines[made:]), lines
    return lines[made:]


def run_make_run(w: Work) -> None:
    """`make run` creates the venv on first use, then runs `vil run`; full: the Table II it prints is the
    README's (every figure of its rows, the paper's included)."""
    assert first_use(w, "run")[-1] == ".venv/bin/vil run"
    done = w.sh(w.line(MAKE_RUN), timeout_s=900)
    if not w.full:
        assert done.stdout.split("\n")[:1] == [".venv/bin/vil run"], done.stdout
        return
    readme = (ROOT / "README.md").read_text().split("`make run` prints", 1)[1]
    sample = readme.split("```", 2)[1]
    assert _table_rows(done.stdout) == _table_rows(sample), done.stdout
    assert "4 run(s) of 40 mission minutes" in words(done.stdout)


def _table_rows(text: str) -> list[str]:
    return [words(line) for line in text.splitlines() if re.match(r"^\s+(pool12|bay24|paper)\s", line)]


def run_make_test(w: Work) -> None:
    """`make test` creates the venv on first use, then runs ruff, mypy and the whole test suite (full: it
    passes; run in the repository, as it lints and types the repository)."""
    tail = first_use(w, "test")
    for step in ("ruff check .", "mypy", "pytest -q -n 2"):
        assert any(step in line for line in tail), (step, tail)
    done = w.sh(w.line(MAKE_TEST), timeout_s=3600, cwd=None if not w.full else ROOT)
    if not w.full:
        steps = [line for line in done.stdout.splitlines() if line.startswith(".venv/bin/")]
        assert [s.split()[0] for s in steps] == [".venv/bin/ruff", ".venv/bin/mypy", ".venv/bin/pytest"], steps


def run_make_bench(w: Work) -> None:
    """`make bench` runs every bench/*.py (the README's eight among them); full: they all succeed."""
    first_use(w, "bench")
    done = w.sh(w.line(MAKE_BENCH), timeout_s=3600)
    if not w.full:
        assert "for b in bench/*.py; do .venv/bin/python $b || exit 1; done" in done.stdout, done.stdout
    listed = {line.split()[-1]
              for line in (THROUGHPUT, FLEET_STEP, SCENARIO_SPEED, TUI_FRAME, LONG_MISSION, MISSION_COST, QUIET_FLOOR,
                          STARTUP)}
    assert listed <= {f"bench/{p.name}" for p in (ROOT / "bench").glob("*.py")}


def bench(w: Work, command: str, *phrases: str) -> str:
    out = words(w.sh(w.line(command), timeout_s=3600).stdout)
    for phrase in phrases:
        assert phrase in out, (phrase, out)
    return out


def run_throughput(w: Work) -> None:
    """msg/s encoded and parsed, over the in-memory pair and UDP, for our message and common's."""
    bench(w, THROUGHPUT, "throughput", "(msg/s)", "encode", "parse", "memory pair", "UDP loopback",
          "AMUSSEL_STATUS", "GLOBAL_POSITION_INT")


def run_fleet_step(w: Work) -> None:
    """one 1 Hz fleet step timed for 12 .. 100,000 aMussels."""
    out = bench(w, FLEET_STEP, "one 1 Hz step", "us/step")
    for n in ("12", "1,000", "10,000", "100,000"):
        assert re.search(rf"│ {n} │ [\d,.]+ │", out), n


def run_scenario_speed(w: Work) -> None:
    """the real-time factor of pool12, bay24, stress240 and bay120 (CI: of a 2-minute pool12)."""
    if not w.full:
        (w.path / "pool12-2m.toml").write_text((w.path / "missions/pool12.toml").read_text()
                                               .replace('duration = "40m"', 'duration = "2m"')
                                               .replace('"areas/', '"missions/areas/')
                                               .replace('"starts/', '"missions/starts/'))
    out = bench(w, SCENARIO_SPEED, "real-time")
    claimed = re.search(r"real-time factor of ([\w, ]+)", _claim(SCENARIO_SPEED)).group(1)  # type: ignore[union-attr]
    names = [n.strip() for n in claimed.split(",")] if w.full else ["pool12"]
    for name in names:
        assert re.search(rf"│ {name}\S* │", out), (name, out)


def _claim(command: str) -> str:
    from doc_examples import all_examples

    return next(e.claim for e in all_examples() if e.command == command)


def run_tui_frame(w: Work) -> None:
    """the time to draw one console frame, with 12, 200 and 1,000 aMussels."""
    out = bench(w, TUI_FRAME)
    for n in ("12", "200", "1000"):
        assert re.search(rf"\b{n} aMussels: [\d.]+ ms/frame", out), (n, out)


def run_long_mission(w: Work) -> None:
    """a long mission against a short one, checkpoints on (full: 4 h against 40 min)."""
    out = bench(w, LONG_MISSION)
    short, long = ("40", "240") if w.full else re.findall(r"--short (\d+) --long (\d+)", w.line(LONG_MISSION))[0]
    assert f"{short} min mission:" in out and f"{long} min mission:" in out, out


def run_platforms(w: Work) -> None:
    """both platforms side by side: the agreement table (full: every part, every scenario and strategy)."""
    out = bench(w, PLATFORMS, "Agreement:", "avg % L / E (diff)", "plans same")
    assert re.search(r"│ pool12 +│ greedy +│ [\d.]+ / [\d.]+ \([+-][\d.]+\)", out), out
    if w.full:
        assert "seeds of 24h" in out and "a simulated year" in out, out


def run_quiet_floor(w: Work) -> None:
    """a quiet second of bay120-sleep, part by part (each row its own process), against the 12x bound."""
    out = bench(w, QUIET_FLOOR, "ms of wall time per mission second", "The bound allows the sleeping day",
                "A saving that both runs share must reach")
    for label in ("bay120, as shipped", "bay120, nobody collected (none)", "bay120-sleep, as shipped",
                  "bay120-sleep, nobody collected", "+ aPads: heartbeats only", "+ fleet: heartbeat only",
                  "+ fleet: not stepped"):
        assert re.search(rf"{re.escape(label)} (40 min|[\d.]+ h) \d+\.\d{{3}} \(\d+\.\d\dx the bound's\)", out), \
            (label, out)


def run_mission_cost(w: Work) -> None:
    """a day's wall time against 40 minutes' (CI: pool12, an hour against 40 minutes)."""
    out = bench(w, MISSION_COST, "Cost against mission time", "Ratios")
    day_h = re.findall(r"--day-h (\S+)", w.line(MISSION_COST))
    hours = float(day_h[0]) if day_h else 24.0
    assert f"{hours:5.2f} h mission:" in out and "ended on 'mission time'" in out, out
    assert re.search(rf"pool12 {hours:g} h / pool12 40 min: wall +[\d.]+x", out), out


def run_startup(w: Work) -> None:
    """`vil --help` and the dialect's import, each in a fresh process."""
    bench(w, STARTUP, "fresh process", "vil --help", "import mavlink_dialect")


def recorded(w: Work) -> None:
    shutil.copytree(w.fixture("recorded_runs") / "runs", w.path / "runs", symlinks=True)


def run_report_latest(w: Work) -> None:
    """the report of the last run, in runs/latest/report/: index.html, its figures, GeoJSON."""
    recorded(w)
    out = words(w.sh(w.line(REPORT_LATEST)).stdout)
    report = w.path / "runs" / "latest" / "report"
    for name in ("index.html", "battery.png", "active.png", "uptime.png", "run.geojson"):
        assert (report / name).stat().st_size, name
    assert "index.html" in out
    assert "<html" in (report / "index.html").read_text().lower()


def run_report_ab(w: Work) -> None:
    """two runs: each one's report in OUT/RUN_NAME/ and, in OUT, a page comparing them and its figures."""
    recorded(w)
    line = w.line(REPORT_AB)
    named = [Path(p).name for p in line.split()[2:4]]
    w.sh(line)
    compare = w.path / "compare"
    for name in named:
        assert (compare / name / "index.html").stat().st_size, name
    for name in ("index.html", "compare_active.png", "compare_cost.png", "compare_uptime.png"):
        assert (compare / name).stat().st_size, name
    page = (compare / "index.html").read_text()
    assert all(name in page for name in named)
