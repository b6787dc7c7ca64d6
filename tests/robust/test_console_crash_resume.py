"""kill -9 of a real `vil gcs --sitl` console mid-mission, with aMussels docked, then `vil gcs --resume`.

The console runs as the operator runs it: its own process on a pseudo-terminal (Textual's real
terminal driver draws into it; the test reads and discards the drawing, and presses q like a
person). The world is the embedded SITL aPad on a paced lockstep clock, 500x real time
(what is watched is mission time: a faster pace only leaves the process less time asleep).

Checked: the resumed mission goes on from the last checkpoint's mission time in the same folder, each
event is in events.jsonl once (and each aPad event and .tlog frame once, in time order), the aMussels
docked at the crash are released before any of them is called up again, and when the console quits
every aMussel is on the seabed or on a slot, none lost.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest
from testkit import PtyConsole, read_jsonl, scenario_variant

from gcs.loop.control import Phase
from gcs.mission import checkpoint
from gcs.mission.checkpoint import load
from gcs.records.run_folder import CHECKPOINT
from mavlink_dialect import tlog
from mussel_sim.vocabulary import MusselState

pytestmark = [pytest.mark.sitl, pytest.mark.slow, pytest.mark.tui]

VIL = [sys.executable, "-m", "gcs.cli"]
GCS = ["gcs", "--sitl", "--speed", "500"]
ROOT = Path(__file__).resolve().parents[2]
RUN = Path("runs") / "console-pool12-run1"
WALL_TIMEOUT_S = 120.0
KILL_AFTER_S = 450.0  # mission time: the second charging cycle, with a history before it
# The missions end at 20 min instead of 40: the crash (~570 s for pool12, ~450 s for pool12x2), the
# resumed loop's releases and its next call-up (pool12's, at ~875 s) all happen before it; at 1200 s
# nothing is on the move. (At 18 min pool12's loop already stays idle after its releases: too close
# to the end to collect, so the resumed mission would call nobody up.)
END_S = 1200.0


def short(name: str, folder: Path) -> list[str]:
    """--scenario for missions/NAME.toml ended at END_S (its name, so its run folder, unchanged)."""
    (folder / "short").mkdir(exist_ok=True)  # the file keeps the shipped one's name: a copy runs under its file's
    path = scenario_variant(name, folder / "short" / f"{name}.toml", {'duration = "40m"': f'duration = "{END_S:.0f}s"'})
    return ["--scenario", str(path)]


def console(cwd: Path, *args: str) -> PtyConsole:
    """`vil gcs ARGS` on a pseudo-terminal of 150 x 46 whose drawing is read and dropped (the last bytes
    kept for a failure message); its stdout, the one line `vil gcs` prints after the console closes, in
    a file of its own (`.stdout`)."""
    return PtyConsole([*VIL, *GCS, *args], cwd, {**os.environ, "PYTHONPATH": str(ROOT)},
                      stdout=cwd / f"stdout-{time.monotonic_ns()}.txt", keep_bytes=4000)


def _killed_once(cwd: Path, what: str, condition: Callable[[], bool], *args: str) -> None:
    """A console `vil gcs ARGS` killed with SIGKILL once `condition()` holds."""
    first = console(cwd, *args)
    try:
        first.wait_until(what, condition, WALL_TIMEOUT_S, period_s=0.02)
        first.kill()
    finally:
        first.close()
    assert first.popen.returncode == -signal.SIGKILL


def test_sigkill_of_the_console_with_amussels_docked_then_resume(tmp_path: Path) -> None:
    run = tmp_path / RUN
    ckpt = run / CHECKPOINT

    def charging_late_enough() -> bool:
        if not ckpt.exists():
            return False
        saved = load(ckpt)
        return saved.time_us > KILL_AFTER_S * 1e6 and saved.loop_statuses[1].phase == Phase.CHARGING_WAIT

    scenario = short("pool12", tmp_path)
    _killed_once(tmp_path, "checkpoint in a charging wait", charging_late_enough, *scenario)
    saved = load(ckpt)  # the last checkpoint before the kill: the resume starts here
    at_s = saved.time_us / 1e6
    docked = sorted(int(i) for i, s in zip(saved.fleet_state.ids, saved.fleet_state.state, strict=True)
                    if s == MusselState.DOCKED)
    assert docked and KILL_AFTER_S < at_s < END_S
    before = (run / "events.jsonl").read_bytes()
    apad_before = read_jsonl(run / "apad1.events.jsonl")

    second = console(tmp_path, *scenario, "--resume")  # finds runs/console-pool12-run1 by its checkpoint
    try:
        # The mission ended, its results written, nothing left to resume.
        second.wait_until("mission end", lambda: b'"mission_end"' in (run / "events.jsonl").read_bytes()
                          and (run / "result.json").exists() and not ckpt.exists(), WALL_TIMEOUT_S, period_s=0.02)
        second.press("q")
        second.popen.wait(WALL_TIMEOUT_S)
    finally:
        second.close()
    assert second.popen.returncode == 0, second.text()[-800:]
    assert second.stdout is not None and f"logs in {RUN}" in second.stdout.read_text()
    assert not any(ckpt.with_suffix(x).exists() for x in (checkpoint.STEPS_SUFFIX, checkpoint.TRACES_SUFFIX))

    # The same folder goes on from the checkpoint: what was logged up to it is kept as it was.
    after = (run / "events.jsonl").read_bytes()
    assert after[: saved.events_bytes] == before[: saved.events_bytes]
    lines = after.decode().splitlines()
    events = [json.loads(line) for line in lines]
    kinds = [e["event"] for e in events]
    assert kinds.count("mission_start") == kinds.count("mission_resume") == kinds.count("mission_end") == 1
    resume = kinds.index("mission_resume")
    assert len(after[: saved.events_bytes].decode().splitlines()) == resume
    assert at_s <= events[resume]["t_s"] < at_s + 10  # on at once, not from 0 and not later
    assert events[resume]["strategy"] == "cautious"
    # Each event once: nothing the killed console logged after its checkpoint is repeated.
    assert all(e["t_s"] <= at_s for e in events[:resume])
    times = [e["t_s"] for e in events]
    assert times == sorted(times) and len(set(lines)) == len(lines)
    end = events[kinds.index("mission_end")]
    assert end["reason"] == "mission time" and end["t_s"] >= END_S

    # The aMussels docked at the crash: released (or still on board), never called up while on board.
    (where,) = [e for e in events if e["event"] == "whereabouts"]
    for mussel in docked:
        mine = [e["event"] for e in events[resume:] if e.get("mussel") == mussel and e["event"] in
                ("call_up", "released", "docked")]
        assert mine[:1] == ["released"] or (mine == [] and mussel in where["slot"]), (mussel, mine)
    assert any(e["event"] == "call_up" for e in events[resume:])  # and the mission really went on

    # The aPad's own log and both .tlogs: cut back to the checkpoint, each record once, in time order.
    apad = read_jsonl(run / "apad1.events.jsonl")
    kept = apad_before[: len(_lines_within(run / "apad1.events.jsonl", saved.log_sizes["apad1.events.jsonl"]))]
    assert apad[: len(kept)] == kept and all(e["t_s"] <= at_s for e in kept)
    assert apad[len(kept)]["event"] == "start" and apad[len(kept)]["t_s"] == pytest.approx(at_s)
    assert [e["t_s"] for e in apad] == sorted(e["t_s"] for e in apad)
    for name in ("gcs.tlog", "apad1.tlog"):
        stamps = [stamp for stamp, _ in tlog.frames(run / name)]
        assert stamps == sorted(stamps), name

    # Every aMussel accounted for when the console quit: on the seabed or on a slot, none lost.
    assert where["lost"] == {} and sorted(where["seabed"] + where["slot"]) == list(range(1, 13))


# --- what `vil gcs --resume` refuses: one line on stderr, exit 2, before the console opens ----------


def _gcs(cwd: Path, *args: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run([*VIL, "gcs", "--sitl", *args], cwd=cwd, capture_output=True, text=True, timeout=60,
                          env=env, stdin=subprocess.DEVNULL)


def _refused(done: subprocess.CompletedProcess[str], *words: str) -> None:
    assert done.returncode == 2 and "Traceback" not in done.stderr, done.stderr
    assert done.stderr.count("\n") == 1 and all(w in done.stderr for w in words), done.stderr


def _left_checkpoint(folder: Path, strategy: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """A short headless run that leaves its last checkpoint behind, as a crash would."""
    from gcs.mission.headless import run_mission
    from gcs.scenario.reader import load_scenario

    monkeypatch.setattr(checkpoint.CheckpointFiles, "remove", checkpoint.CheckpointFiles.close)
    run_mission(load_scenario("pool12").with_overrides(strategy=strategy, duration_s=60.0), folder)
    monkeypatch.undo()
    assert (folder / CHECKPOINT).exists()


def test_resume_with_nothing_to_resume_is_refused(tmp_path: Path) -> None:
    _refused(_gcs(tmp_path, "--resume"), "nothing to resume", "console-pool12")
    folder = tmp_path / "runs" / "console-pool12-run1"
    folder.mkdir(parents=True)  # a console that quit: its checkpoint is gone
    _refused(_gcs(tmp_path, "--resume", "--out", str(folder)), "no checkpoint to resume from")


def test_a_corrupt_checkpoint_is_refused(tmp_path: Path) -> None:
    folder = tmp_path / "runs" / "console-pool12-run1"
    folder.mkdir(parents=True)
    (folder / "console.json").write_text('{"scenario": "pool12", "epoch_us": 1591920000000000}')
    (folder / CHECKPOINT).write_bytes(b"\x80\x05garbage")
    _refused(_gcs(tmp_path, "--resume"), str(Path("runs") / "console-pool12-run1" / CHECKPOINT))


def test_a_checkpoint_of_another_run_or_without_its_epoch_is_refused_and_the_logs_are_left_alone(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    folder = tmp_path / "console-pool12-run1"
    _left_checkpoint(folder, "greedy", monkeypatch)  # the console's pool12 collects "cautious"
    events = (folder / "events.jsonl").read_bytes()
    (folder / "console.json").write_text('{"scenario": "pool12"}')  # written before consoles kept the epoch
    _refused(_gcs(tmp_path, "--resume", "--out", str(folder)), "epoch_us")
    (folder / "console.json").write_text('{"scenario": "pool12", "epoch_us": 1591920000000000}')
    _refused(_gcs(tmp_path, "--resume", "--out", str(folder)), "greedy", "cautious")
    assert (folder / "events.jsonl").read_bytes() == events  # nothing cut for a resume that did not happen


def test_sigkill_of_a_two_apad_console_then_resume(tmp_path: Path) -> None:
    """A swarm's console checkpoints like a single aPad's: killed with aMussels docked, resumed from
    its checkpoint, both loops settle the crash and the mission runs to its end, each event once."""
    run = tmp_path / "runs" / "console-pool12x2-run1"
    ckpt = run / CHECKPOINT
    scenario = short("pool12x2", tmp_path)

    def docked_late_enough() -> bool:
        if not ckpt.exists():
            return False
        saved = load(ckpt)
        return saved.time_us > KILL_AFTER_S * 1e6 and len(saved.loop_statuses) == 2 and bool(
            (saved.fleet_state.state == MusselState.DOCKED).any())

    _killed_once(tmp_path, "checkpoint with aMussels docked", docked_late_enough, *scenario)
    saved = load(ckpt)
    at_s = saved.time_us / 1e6
    before = (run / "events.jsonl").read_bytes()

    second = console(tmp_path, *scenario, "--resume")
    try:
        second.wait_until("mission end", lambda: (run / "events.jsonl").read_bytes().count(b'"mission_end"') == 2
                          and not ckpt.exists(), WALL_TIMEOUT_S, period_s=0.02)
        second.press("q")
        second.popen.wait(WALL_TIMEOUT_S)
    finally:
        second.close()
    assert second.popen.returncode == 0, second.text()[-800:]
    assert not ckpt.exists()
    after = (run / "events.jsonl").read_bytes()
    assert after[: saved.events_bytes] == before[: saved.events_bytes]
    lines = after.decode().splitlines()
    events = [json.loads(line) for line in lines]
    resumed = [e for e in events if e["event"] == "mission_resume"]
    assert sorted(e["apad"] for e in resumed) == [1, 2] and all(at_s <= e["t_s"] < at_s + 10 for e in resumed)
    assert all(e["t_s"] <= at_s for e in events[: len(before[: saved.events_bytes].decode().splitlines())])
    times = [e["t_s"] for e in events]
    assert times == sorted(times) and len(set(lines)) == len(lines)
    assert [e["reason"] for e in events if e["event"] == "mission_end"] == ["mission time"] * 2
    (where,) = [e for e in events if e["event"] == "whereabouts"]
    assert where["lost"] == {} and sorted(where["seabed"] + where["slot"]) == list(range(1, 13))
    result = json.loads((run / "result.json").read_text())
    assert [a["sysid"] for a in result["apads"]] == [1, 2] and result["end_reason"] == "mission time"


def _lines_within(path: Path, size: int) -> list[bytes]:
    """The whole lines in the first `size` bytes of a log."""
    return path.read_bytes()[:size].splitlines()
