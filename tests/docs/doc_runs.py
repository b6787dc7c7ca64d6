"""How the `vil run` examples run and what of their claims is checked (the registry's "runs" room)."""

from __future__ import annotations

import json
import math
import os
import re
import signal
import subprocess
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from doc_harness import Work, words

SEED3 = "vil run missions/pool12.toml --strategy greedy --seed 3 --draw-fleet --json out.json"
SEEDS20 = "vil run --seeds 20"
POOL12X2 = "vil run pool12x2"
BAY120 = "vil run bay120 --fail-apad 3:600s"
LOSS = "vil run pool12 --strategy greedy --loss 0.2 --latency 200ms --duplicate 0.05"
OUTAGE = "vil run pool12 --strategy greedy --outage 92s:112s"
SIGNING = "VIL_SIGNING_KEY=passphrase vil run pool12"
RESUME = "vil run pool12 --resume"
COPY = "cp missions/pool12.toml mine.toml"
SED = """sed -i 's#"areas/#"missions/areas/#; s#"starts/#"missions/starts/#' mine.toml"""
MINE = "vil run mine.toml --strategy greedy"
SLEEP_DAY = "vil run missions/bay120-sleep.toml --duration 24h"
EVENT_DAY = "vil run bay120-sleep --duration 24h --platform event"
SLACK_RUN = "vil run pool12 --strategy docs/examples/slack_first.py:slack_first,cautious"
POOL12_NAME = "vil run pool12 --strategy NAME --seeds 20 --json pool12-NAME.json"
BAY24_NAME = "vil run bay24 --strategy NAME --seeds 20 --json bay24-NAME.json"


def result(w: Work, run: str = "latest") -> dict[str, Any]:
    data: dict[str, Any] = json.loads((w.path / "runs" / run / "result.json").read_text())
    return data


def events(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def figures(stdout: str, label: str) -> list[str]:
    """The rows of `label` ("pool12 greedy s3") in the tables `vil run` prints: their figures."""
    rows = [words(line)[len(label):].strip() for line in stdout.splitlines() if words(line).startswith(label + " ")]
    assert rows, (label, stdout)
    return rows


def run_seed3(w: Work) -> None:
    """seed 3's own fleet: drawn from the seed (not the saved start), so its figures are not seed 1's."""
    done = w.sh(w.line(SEED3))
    seed1 = w.line(SEED3).replace("--seed 3", "--seed 1").replace("out.json", "seed1.json")
    other = w.sh(seed1)
    mine, theirs = (json.loads((w.path / name).read_text()) for name in ("out.json", "seed1.json"))
    assert mine["seed"] == 3 and theirs["seed"] == 1
    assert figures(done.stdout, "pool12 greedy s3") != figures(other.stdout, "pool12 greedy s1")
    batteries = [m["start_battery"] for m in mine["mussels"]]
    assert batteries != [m["start_battery"] for m in theirs["mussels"]]
    saved = json.loads((w.path / "missions/starts/pool12.geojson").read_text())["features"]
    assert len(batteries) == len(saved) == 12
    assert all(abs(b - f["properties"]["battery"]) > 1e-6 for b, f in zip(batteries, saved, strict=True))


def run_seeds20(w: Work) -> None:
    """pool12 and bay24, cautious/greedy/none, on fleets drawn from seeds 1..N: a row each, N runs each."""
    line = w.line(SEEDS20)
    n = int(re.search(r"--seeds (\d+)", line).group(1))  # type: ignore[union-attr]
    out = words(w.sh(line, timeout_s=3600).stdout)
    assert f"{6 * n} runs, fleets drawn from seeds 1..{n}" in out
    for scenario in ("pool12", "bay24"):
        for strategy in ("cautious", "greedy", "none"):
            assert re.search(rf"\b{scenario} {strategy} {n} \d", out), (scenario, strategy, out)
            assert len(list((w.path / "runs").glob(f"{scenario}-{strategy}-seed*-run1"))) == n


def run_pool12x2(w: Work) -> None:
    """two aPads share the pool12 fleet: six aMussels each, the fleet split between them once, each
    aPad its own loop (a row per aPad, each ending on its own)."""
    out = words(w.sh(w.line(POOL12X2)).stdout)
    r = result(w)
    shares = [sorted(a["share_at_end"]) for a in r["apads"]]
    assert [a["sysid"] for a in r["apads"]] == [1, 2] and len(r["mussels"]) == 12
    assert sorted(shares[0] + shares[1]) == list(range(1, 13)) and [len(s) for s in shares] == [6, 6]
    assert all(a["end_reason"] == "mission time" and a["phase_s"] for a in r["apads"])
    assert "Per aPad" in out and re.search(r"\b1 6 [\d.]+ ", out) and re.search(r"\b2 6 [\d.]+ ", out)


def run_bay120(w: Work) -> None:
    """five aPads, 120 aMussels; aPad 3 made silent at 600 s (CI: 60 s) is lost, and its share re-shared."""
    line = w.line(BAY120)
    at_s = int(re.search(r"--fail-apad 3:(\d+)s", line).group(1))  # type: ignore[union-attr]
    out = words(w.sh(line).stdout)
    r = result(w)
    assert len(r["apads"]) == 5 and len(r["mussels"]) == 120
    happened = r["happened"]
    assert happened["failed_apads"] == [{"apad": 3, "at_s": float(at_s)}]
    assert [a["apad"] for a in happened["apads_lost"]] == [3] and happened["reshares"] >= 1
    mm = f"{at_s // 60:02d}"
    assert f"aPad 3 made to fail at {mm}:00" in out and f"aPad 3 lost at {mm}:" in out
    shares = [set(a["share_at_end"]) for a in r["apads"] if a["sysid"] != 3]
    assert len(set().union(*shares)) == 120  # everyone of aPad 3's share has another aPad now


def run_loss(w: Work) -> None:
    """the aPad link over real UDP through the seeded fault proxy: about a fifth of the datagrams
    dropped and some duplicated in each direction, delayed 200 ms, and the mission still ends whole."""
    w.sh(w.line(LOSS))
    r = result(w)
    assert r["happened"]["faults"] == {"loss": 0.2, "latency_s": 0.2, "duplicate": 0.05}
    m = r["messages"]
    for way in ("to_apad", "to_gcs"):
        sent = m[f"proxy_{way}_forwarded"] + m[f"proxy_{way}_dropped"]
        assert 0.1 < m[f"proxy_{way}_dropped"] / sent < 0.3 and m[f"proxy_{way}_duplicated"] > 0
    assert json.loads((w.path / "runs/latest/endpoints.json").read_text())["proxy"]
    assert r["end_reason"] == "mission time" and all(x["where"] != "lost" for x in r["whereabouts"])


def run_outage(w: Work) -> None:
    """20 s of total link loss during a Go To: the aPad's failsafe holds (FS_GCS_TIMEOUT after the last
    heartbeat), the GCS resumes the Go To once the link is back, and the mission goes on to its end."""
    out = words(w.sh(w.line(OUTAGE)).stdout)
    run = w.path / "runs" / "latest"
    apad = events(run / "apad1.events.jsonl")
    holds = [e for e in apad if e["event"] == "failsafe"]
    assert holds and 92 < holds[0]["t_s"] < 112 and holds[0]["reason"] == "gcs heartbeat lost", holds
    moves = [e for e in apad if e["event"] == "primitive"]
    (goto,) = [e for e in moves if e["t_s"] < holds[0]["t_s"]][-1:]  # what the aPad was doing: a Go To
    assert (goto["primitive"], goto["progress"]) == ("GOTO", "IN_PROGRESS"), goto
    after = [e for e in moves if e["t_s"] > 112 and e["primitive"] == "GOTO"]
    assert after and (after[0]["target_x_m"], after[0]["target_y_m"]) == (goto["target_x_m"], goto["target_y_m"])
    gcs = events(run / "events.jsonl")
    (resumed,) = [e for e in gcs if e["event"] == "goto_resumed"]
    assert resumed["t_s"] >= 112
    later = [e["event"] for e in gcs if e["t_s"] > resumed["t_s"]]
    assert "docked" in later and later[-1] == "mission_end"
    assert "link faults: outage 01:32-01:52" in out and "failsafe hold x1" in out and "Go To resumed" in out


def signed(path: Path) -> tuple[int, int]:
    """(signed frames, all frames) of a .tlog."""
    from mavlink_dialect import mavlink, tlog

    frames = [frame for _, frame in tlog.frames(path)]
    return sum(bool(f[2] & mavlink.MAVLINK_IFLAG_SIGNED) for f in frames), len(frames)


def run_signing(w: Work) -> None:
    """MAVLink 2 signing from the environment: every frame the GCS and the aPad logged is signed and
    none was refused; `vil sitl` takes the key too."""
    w.sh(w.line(SIGNING))
    run = w.path / "runs" / "latest"
    for log in ("gcs.tlog", "apad1.tlog"):
        n_signed, n = signed(run / log)
        assert n > 100 and n_signed == n, (log, n_signed, n)
    r = result(w)
    assert r["messages"]["gcs_bad_data"] == 0 and r["messages"]["apad_bad_data"] == 0
    sitl = words(w.sh("vil sitl --help").stdout)
    assert "--signing-key FILE MAVLink 2 signing" in sitl and "$VIL_SIGNING_KEY" in sitl


def run_resume(w: Work) -> None:
    """continue a killed run from its checkpoint: the run started with the same flags is killed with
    SIGKILL mid-mission, and `--resume` finishes it in its folder, the mission replayed to the checkpoint
    and each event logged once; in the full run, pool12x2's too."""
    for scenario in ("pool12", "pool12x2") if w.full else ("pool12",):
        resume = w.line(RESUME).replace("pool12", scenario, 1)
        _kill_then_resume(w, resume.replace(" --resume", ""), resume, scenario)


def _kill_then_resume(w: Work, start: str, resume: str, scenario: str) -> None:
    from gcs.mission.checkpoint import load as load_checkpoint
    from gcs.records.run_folder import CHECKPOINT

    folder = w.path / "runs" / f"{scenario}-cautious-seed1-run1"
    proc = subprocess.Popen(["bash", "-c", f"exec {start}"], cwd=w.path, env=w.env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 120
        while not ((folder / CHECKPOINT).exists() and load_checkpoint(folder / CHECKPOINT).time_us > 120e6):
            assert proc.poll() is None, f"{start} ended before a checkpoint past 120 s"
            assert time.monotonic() < deadline
            time.sleep(0.01)
        os.kill(proc.pid, signal.SIGKILL)
    finally:
        proc.wait(10)
    killed_at_s = load_checkpoint(folder / CHECKPOINT).time_us / 1e6
    assert not (folder / "result.json").exists()
    w.sh(resume)
    kinds = [(e["event"], e["t_s"]) for e in events(folder / "events.jsonl")]
    assert ("mission_resume", killed_at_s) in kinds and kinds[-1][0] == "mission_end"
    resumed = kinds.index(("mission_resume", killed_at_s))
    starts = [i for i, (k, _) in enumerate(kinds) if k == "mission_start"]
    assert len(starts) == len(result(w, folder.name)["apads"]) and max(starts) < resumed  # each event once
    assert [p.name for p in (w.path / "runs").iterdir() if p.name.startswith(f"{scenario}-")] == [folder.name]
    assert (w.path / "runs" / "latest").resolve() == folder.resolve()  # resumed in its folder, no new one
    assert result(w, folder.name)["end_reason"] == "mission time" and not (folder / CHECKPOINT).exists()


def run_sleep_day(w: Work) -> None:
    """bay120-sleep's day: its file says 40 minutes, the flag runs the duration given; 24 h at theta 30 are
    30 simulated days (a row per day kept), every aMussel alive at the end, none ever depleted."""
    line = w.line(SLEEP_DAY)
    duration_s = {"24h": 86400.0, "6m": 360.0}[line.split("--duration ")[1].split()[0]]
    w.sh(line, timeout_s=7200)
    r = result(w)
    assert r["scenario"] == "bay120-sleep" and r["duration_s"] == duration_s and r["theta"] == 30
    assert "duration = \"40m\"" in (w.path / "missions/bay120-sleep.toml").read_text()
    assert len(r["mussels"]) == 120 and all(m["first_depleted_s"] is None for m in r["mussels"])
    if w.full:
        assert len(r["days"]) == 30


def run_event_day(w: Work) -> None:
    """The sleeping day on the event platform: the result names it, no .tlog is written, the summary says
    so, and every aMussel is alive at the end (as lockstep's day: docs/platforms.md's agreement)."""
    line = w.line(EVENT_DAY)
    duration = line.split("--duration ")[1].split()[0]
    done = w.sh(line, timeout_s=3600)
    r = result(w)
    assert r["platform"] == "event" and r["scenario"] == "bay120-sleep"
    assert r["duration_s"] == {"24h": 86400.0, "1h": 3600.0}[duration]
    assert not list((w.path / "runs" / "latest").glob("*.tlog"))
    assert "on the event platform" in words(done.stdout) and "no .tlog" in words(done.stdout)
    assert len(r["mussels"]) == 120 and all(m["first_depleted_s"] is None for m in r["mussels"])
    if w.full:
        assert len(r["days"]) == 30


def run_own_scenario(w: Work) -> None:
    """A copy of pool12 elsewhere: as copied, its paths are taken from its own folder (one line says
    so, exit 2); the sed line points them back at the shipped files, and it runs as pool12 does, under its
    own name (its runs are not pool12's)."""
    w.sh(w.line(COPY))
    refused = w.sh(w.line(MINE), expect=2)
    assert refused.stderr.count("\n") == 1 and "relative to the scenario file's folder" in refused.stderr
    assert str(w.path.resolve()) in refused.stderr
    w.sh(w.line(SED))
    done = w.sh(w.line(MINE))
    assert "mine-greedy-seed1-run1/" in words(done.stdout) and not list((w.path / "runs").glob("pool12-*"))
    assert result(w)["strategy"] == "greedy" and len(result(w)["mussels"]) == 12


def run_slack_first(w: Work) -> None:
    """a strategy in a file of its own, run beside a shipped one: a row and a run folder each, named by
    the function, and the plans it made logged under its name."""
    out = words(w.sh(w.line(SLACK_RUN)).stdout)
    assert "pool12 slack_first s1 " in out and "pool12 cautious s1 " in out
    folder = w.path / "runs" / "pool12-slack_first-seed1-run1"
    plans = [e for e in events(folder / "events.jsonl") if e["event"] == "plan_collection"]
    assert plans and {e["strategy"] for e in plans} == {"slack_first"}
    assert result(w, folder.name)["strategy"] == "slack_first"


STRATEGIES = ("none", "greedy", "cautious", "weighted", "least_slack", "route_optimal", "rolling", "lookahead",
              "keep_alive")
CI_NAME = "lookahead"
T19 = 2.093  # Student's t, 95 % two-sided, 19 degrees of freedom


@dataclass(frozen=True)
class Row:
    figures: list[str]  # avg, min, cost: "64.1 ± 1.1"
    front: bool
    dominates_cautious: bool


def _measured(doc: str) -> dict[tuple[str, str], Row]:
    """docs/strategies.md's Measured table, as printed: (scenario, strategy) -> its row."""
    table: dict[tuple[str, str], Row] = {}
    for line in doc.split("## Measured", 1)[1].split("\n## ", 1)[0].splitlines():
        cells = re.match(r"^(pool12|bay24)\s+(\w+)\s+([\d.]+ ± [\d.]+)\s+([\d.]+ ± [\d.]+)\s+(\d+ ± +\d+)(.*)$", line)
        if cells:
            rest = cells.group(6).split()
            table[cells.group(1), cells.group(2)] = Row([re.sub(r" +", " ", c) for c in cells.groups()[2:5]],
                                                        rest[:1] == ["yes"], "dominates cautious" in line)
    assert len(table) == 2 * len(STRATEGIES), table
    return table


def _mean_ci(values: list[float], digits: int) -> str:
    n = len(values)
    mean = sum(values) / n
    sd = math.sqrt(sum((v - mean) ** 2 for v in values) / (n - 1))
    return f"{mean:.{digits}f} ± {T19 * sd / math.sqrt(n):.{digits}f}"


def _strategies_on(w: Work, command: str, scenario: str) -> None:
    """One strategy's seeds (CI), or every strategy's 20 against the doc's Measured table (full: every
    row that differs is named at once, with the figures the runs gave)."""
    table = _measured(_doc("docs/strategies.md"))
    means: dict[str, tuple[float, float, float]] = {}
    wrong: list[str] = []
    for name in STRATEGIES if w.full else (CI_NAME,):
        line = w.line(command).replace("NAME", name)
        n = int(re.search(r"--seeds (\d+)", line).group(1))  # type: ignore[union-attr]
        w.sh(line, timeout_s=3600)
        runs = json.loads((w.path / f"{scenario}-{name}.json").read_text())
        assert [r["seed"] for r in runs] == list(range(1, n + 1))
        assert {(r["scenario"], r["strategy"]) for r in runs} == {(scenario, name)}
        avg, low, cost = ([r["uptime"]["avg"] for r in runs], [r["uptime"]["min"] for r in runs],
                          [r["cost_m"] for r in runs])
        means[name] = (sum(avg) / n, sum(low) / n, sum(cost) / n)
        got = [_mean_ci(avg, 1), _mean_ci(low, 1), _mean_ci(cost, 0)]
        if w.full and got != table[scenario, name].figures:
            wrong.append(f"{scenario} {name}: the doc says {table[scenario, name].figures}, the runs give {got}")
    if w.full:
        for name, row in ((k[1], v) for k, v in table.items() if k[0] == scenario):
            if _on_front(name, means) != row.front or _beats(means[name], means["cautious"]) != row.dominates_cautious:
                wrong.append(f"{scenario} {name}: front {_on_front(name, means)}, "
                             f"dominates cautious {_beats(means[name], means['cautious'])}: not what the doc says")
        assert wrong == [], "docs/strategies.md's Measured table:\n" + "\n".join(wrong)


def _beats(a: tuple[float, float, float], b: tuple[float, float, float]) -> bool:
    """At least as good in avg and min uptime (up) and cost (down), better in one."""
    return a[0] >= b[0] and a[1] >= b[1] and a[2] <= b[2] and a != b


def _on_front(name: str, means: dict[str, tuple[float, float, float]]) -> bool:
    return not any(_beats(other, means[name]) for other in means.values())


def _doc(name: str) -> str:
    return (Path(__file__).resolve().parents[2] / name).read_text()


def run_pool12_name(w: Work) -> None:
    """each strategy on pool12's 20 drawn fleets, to the JSON named after it; full: docs/strategies.md's
    figures (mean and 95 % interval of avg and min uptime and cost) are what the runs give."""
    _strategies_on(w, POOL12_NAME, "pool12")


def run_bay24_name(w: Work) -> None:
    """the same on bay24."""
    _strategies_on(w, BAY24_NAME, "bay24")


# docs/acoustic.md
ACOUSTIC_FIGURES = "python docs/acoustic_figures.py --figure docs/acoustic-delivery.png"
VIL_MODEM = "vil modem --nodes 5@300,0,5 9@2400,0,5"
FUZZ_MODEM = ".venv/bin/python bench/fuzz_modem.py"


def run_acoustic_figures(w: Work) -> None:
    """the figure is a PNG; the delivery ranges it prints and the TDMA frames of pool12, bay24 and bay120
    are the page's, figure for figure."""
    line = w.line(ACOUSTIC_FIGURES)
    out = words(w.sh(line, timeout_s=600).stdout)
    assert (w.path / line.split("--figure ")[1].split()[0]).read_bytes()[:4] == b"\x89PNG"
    page = words(_doc("docs/acoustic.md"))
    reach = re.findall(r"(\d+)-byte packets: delivered with p >= 0.9 to ([\d,]+) m, p >= 0.1 to ([\d,]+) m", out)
    assert [n for n, _, _ in reach] == ["16", "64"], out
    for _, far90, far10 in reach:
        assert f"{far90} m" in page and f"{far10} m" in page, (far90, far10)
    tdma = _doc("docs/acoustic.md").split("\n## TDMA", 1)[1].split("\n## ", 1)[0]  # the frames' table
    rows = re.findall(r"^\| (pool12|bay24|bay120) +\|(.*)\|$", tdma, re.MULTILINE)
    assert [name for name, _ in rows] == ["pool12", "bay24", "bay120"]
    for name, cells in rows:
        figures = " │ ".join(c.strip() for c in cells.split("|"))
        assert f"│ {name} │ {figures} │" in out, (name, figures, out)


def run_vil_modem(w: Work) -> None:
    """the first line is the pty; through it (pyserial, the GCS's driver) unit 5 answers a ping with 300 m
    and unit 9, 2.4 km away, with #TO; SIGTERM ends it with its counts."""
    from acoustic.nanomodem.driver import ModemDriver, Outcome
    from acoustic.nanomodem.ports import SerialPort
    from acoustic.nanomodem.replies import Range
    from missiontime.clocks import WallClock

    modem = w.start(w.line(VIL_MODEM))
    try:
        device = modem.wait_output(r"^(/dev/\S+)$", timeout_s=60.0).group(1)
        driver = ModemDriver(SerialPort(device), WallClock())
        near = driver.ping(5)
        assert near.ok and isinstance(near.reply, Range) and abs(near.reply.range_m(1500.0) - 300.0) < 0.1
        assert driver.ping(9).outcome is Outcome.TIMEOUT
        driver.port.close()
    finally:
        code = modem.stop()
    assert code == 0 and "vil modem: stopped; " in modem.output and "timeout 1" in modem.output, modem.output


def run_fuzz_modem(w: Work) -> None:
    """random and mutated serial inputs through the parsers and the emulator: 0 uncaught exceptions, the
    drops counted by reason (full: 120,000 inputs)."""
    out = words(w.sh(w.line(FUZZ_MODEM), timeout_s=3600).stdout)
    assert "half random, half mutated" in out and "uncaught exceptions: 0" in out, out
    assert "command parser: stray_byte" in out and "reply parser (driver): stray_byte" in out, out
    if w.full:
        assert "120,000 inputs" in out, out


ACOUSTIC_POOL = "vil run missions/pool12-acoustic.toml"
ACOUSTIC_BAY = "vil run missions/bay24-acoustic.toml"
ACOUSTIC_BAY120 = "vil run missions/bay120-acoustic.toml"
ACOUSTIC_LINE = re.compile(
    r"(\S+) (\S+) s1: acoustic: TDMA frame ([\d.]+) s, ([\d,]+) of ([\d,]+) reports heard, knowledge ([\d.]+) s old "
    r"\(median; max (\d+) s\), battery estimate off by ([\d.]+) % \(max ([\d.]+) %\), call-ups acknowledged "
    r"(\d+) of (\d+) \((\d+) retries\)")


def _acoustic_run(w: Work, command: str, frame_s: str) -> None:
    out = words(w.sh(w.line(command), timeout_s=900).stdout)
    said = ACOUSTIC_LINE.search(out)
    assert said is not None and said[3] == frame_s, out
    heard, sent = int(said[4].replace(",", "")), int(said[5].replace(",", ""))
    assert 0 < heard <= sent and int(said[10]) <= int(said[11]), out
    if w.full:  # the doc's row of this scenario with the channel on is what the run printed
        name = said[1].removesuffix("-acoustic")
        figures = re.search(rf"{said[1]} {said[2]} s1 +([\d.]+) +[\d.]+ +([\d.]+) +([\d.]+)", out)
        assert figures is not None, out
        row = next(line for line in _doc("docs/acoustic.md").splitlines()
                   if re.match(rf"^\| {name} +\| {said[2]} +\| on ", line))
        cells = [c.strip() for c in row.strip("|").split("|")]
        assert cells[3:6] == [figures[1], figures[2], figures[3]], (cells, figures.groups())
        assert cells[6] == f"{said[4]} of {said[5]}" and cells[9] == f"{said[10]} of {said[11]}", cells
        assert cells[7] == f"{said[6]} s / {int(said[7]):,} s", cells
        assert cells[8] == f"{said[8]} % / {said[9]} %", cells


def run_acoustic_pool(w: Work) -> None:
    """the run's acoustic line (pool12's TDMA frame, reports heard of sent, call-ups acknowledged); as written
    (40 min): the doc's pool12 row with the channel on is what it printed, figure for figure."""
    _acoustic_run(w, ACOUSTIC_POOL, "17.26")


def run_acoustic_bay(w: Work) -> None:
    """the same for bay24's row (its frame: 33.81 s)."""
    _acoustic_run(w, ACOUSTIC_BAY, "33.81")


def run_acoustic_bay120(w: Work) -> None:
    """the same for bay120's row (five aPads on the GCS's one unit; its frame: 169.05 s)."""
    _acoustic_run(w, ACOUSTIC_BAY120, "169.05")


ACOUSTIC_KEEP_ALIVE = ("vil run missions/pool12-acoustic.toml --strategy keep_alive --seeds 20 --jobs 2",
                       "vil run missions/bay24-acoustic.toml --strategy keep_alive --seeds 20 --jobs 2")
KEEP_ALIVE_SEED = re.compile(r"keep_alive s\d+: acoustic: .*? battery estimate off by [\d.]+ % \(max ([\d.]+) %\)")
KEEP_ALIVE_MEANS = re.compile(r"(\w+)-acoustic keep_alive (\d+) ([\d.]+±[\d.]+) [\d.]+±[\d.]+ ([\d.]+±[\d.]+) "
                              r"(\d+±\d+)")


def run_acoustic_keep_alive(w: Work) -> None:
    """every seed's acoustic line: the worst battery estimate error at most 0.05 % (keep_alive sends sleep
    orders, across which the belief runs on); as written (seeds 1-20), the doc's keep_alive table is what
    the two runs printed, mean and spread."""
    for command in ACOUSTIC_KEEP_ALIVE:
        out = words(w.sh(w.line(command), timeout_s=1800).stdout)
        worst = [float(x) for x in KEEP_ALIVE_SEED.findall(out)]
        assert worst and max(worst) <= 0.05, out
        if w.full:
            means = KEEP_ALIVE_MEANS.search(out)
            assert means is not None and means[2] == "20", out
            row = next(line for line in _doc("docs/acoustic.md").splitlines()
                       if re.match(rf"^\| {means[1]} +\| +[\d.]+ +\| +[\d.]+ ± ", line))
            cells = [c.strip().replace(" ± ", "±") for c in row.strip("|").split("|")]
            assert cells[2:5] == [means[3], means[4], means[5]], (cells, means.groups())
