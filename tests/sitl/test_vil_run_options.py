"""`vil.run` takes every option `vil run` takes (issue 36: one way to start a run): link faults,
signing and failing aPads, resume. Each gives the figures `vil run` gives with the same flags; a
bad value is `vil.Error`, one line, before anything is made."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

import vil
from gcs.mission.checkpoint import CheckpointError, load
from gcs.records.run_folder import RunFolder
from mavlink_dialect import tlog

pytestmark = [pytest.mark.sitl]

ROOT = Path(__file__).resolve().parents[2]
VIL = [sys.executable, "-m", "gcs.cli", "run"]
WALL_TIMEOUT_S = 120.0
SIGNED = 0x01  # MAVLink 2 incompat flag: the frame carries a signature


def vil_run(*args: str) -> dict[str, Any]:
    """`vil run ARGS` as a process; its result.json."""
    out = Path(args[args.index("--out") + 1]).with_suffix(".json")
    done = subprocess.run([*VIL, *args, "--json", str(out)], capture_output=True, text=True, timeout=WALL_TIMEOUT_S,
                          env={**os.environ, "PYTHONPATH": str(ROOT), "VIL_SIGNING_KEY": ""})
    assert done.returncode == 0, done.stderr
    return figures(json.loads(out.read_text()))


def figures(result: dict[str, Any]) -> dict[str, Any]:
    """result.json without what differs between two runs of the same mission (wall time, folder)."""
    return {k: v for k, v in result.items() if k not in ("wall_s", "out_dir")}


def test_vil_run_with_link_faults_gives_the_figures_of_vil_run_with_the_same_flags(tmp_path: Path) -> None:
    r = vil.run("pool12", strategy="greedy", seed=3, duration="10min", loss=0.2, latency="200ms", jitter=0.05,
                duplicate=0.05, outages=["92s:112s"], out=tmp_path / "api")
    cli = vil_run("pool12", "--strategy", "greedy", "--seed", "3", "--duration", "10min", "--loss", "0.2",
                  "--latency", "200ms", "--jitter", "50ms", "--duplicate", "0.05", "--outage", "92s:112s",
                  "--out", str(tmp_path / "cli"))
    assert figures(r.raw.to_json()) == cli
    assert cli["happened"]["faults"] == {"loss": 0.2, "latency_s": 0.2, "jitter_s": 0.05, "duplicate": 0.05,
                                         "outages_s": [[92.0, 112.0]]}
    assert cli["messages"]["proxy_to_gcs_dropped"] > 0 and cli["messages"]["proxy_to_apad_duplicated"] > 0
    assert (r.folder / "command.txt").read_text() == (
        f'vil.run("{ROOT / "missions" / "pool12.toml"}", strategy=\'greedy\', seed=3, duration=\'10min\', '
        f"loss=0.2, latency='200ms', jitter=0.05, duplicate=0.05, outages=('92s:112s',), out='{tmp_path / 'api'}')\n")


def test_vil_run_signed_with_a_failing_apad_gives_the_figures_of_vil_run_with_the_same_flags(tmp_path: Path) -> None:
    key_file = tmp_path / "key.txt"
    key_file.write_text("secret\n")
    r = vil.run("pool12x2", duration="6min", signing_key="secret", fail_apads=["2:2min"], out=tmp_path / "api")
    cli = vil_run("pool12x2", "--duration", "6min", "--signing-key", str(key_file), "--fail-apad", "2:2min",
                  "--out", str(tmp_path / "cli"))
    assert figures(r.raw.to_json()) == cli
    lost = [a["lost_at_s"] for a in cli["apads"] if a.get("lost_at_s") is not None]
    assert len(lost) == 1 and 120 < lost[0] < 140  # aPad 2, silent from 2 min, declared lost by its silence
    frames = [frame for _, frame in tlog.frames(r.folder / "gcs.tlog")]
    assert frames and all(f[0] == 0xFD and f[2] & SIGNED for f in frames)  # every frame the GCS kept signed
    assert "secret" not in (r.folder / "command.txt").read_text()  # a passphrase is given again, not kept


def test_vil_run_resumes_a_killed_vil_run_to_the_figures_of_a_run_never_interrupted(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "runs"
    folder = RunFolder(out / "pool12-greedy-seed3-run1")
    args = ["pool12", "--strategy", "greedy", "--seed", "3", "--duration", "20min", "--loss", "0.1", "--out", str(out)]
    proc = subprocess.Popen([*VIL, *args], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "PYTHONPATH": str(ROOT)})
    try:
        deadline = time.monotonic() + WALL_TIMEOUT_S
        while True:  # a few checkpoints into the mission
            assert proc.poll() is None and time.monotonic() < deadline, proc.communicate()
            try:
                if folder.checkpoint.exists() and load(folder.checkpoint).time_us >= 240e6:
                    break
            except CheckpointError:  # caught mid-write
                pass
            time.sleep(0.02)
        proc.kill()
    finally:
        proc.communicate(timeout=WALL_TIMEOUT_S)
    assert proc.returncode == -signal.SIGKILL and not folder.result.exists()
    killed_at_s = load(folder.checkpoint).time_us / 1e6

    options: dict[str, Any] = dict(strategy="greedy", seed=3, duration="20min", loss=0.1)
    resumed = vil.run("pool12", **options, out=out, resume=True)
    assert resumed.folder == folder.path and not folder.checkpoint.exists()
    assert f"resuming {folder.path} from its checkpoint" in capsys.readouterr().err
    events = [json.loads(line) for line in folder.events.read_text().splitlines()]
    assert [e["t_s"] for e in events if e["event"] == "mission_resume"] == [pytest.approx(killed_at_s)]
    whole = vil.run("pool12", **options, out=tmp_path / "whole")
    assert figures(resumed.raw.to_json()) == figures(whole.raw.to_json())
    assert resumed.raw.end_reason == "mission time" and resumed.raw.happened["faults"]["loss"] == 0.1


@pytest.mark.parametrize("options, words", [
    (dict(loss=1.5), "loss: 1.5 is outside [0, 1]"),
    (dict(duplicate=1.0), "duplicate: must be a fraction below 1"),
    (dict(latency="9s"), "latency: 9s is more than 5 s"),
    (dict(jitter=-1), "jitter: -1.0 is outside [0.0, 5.0]"),
    (dict(outages=["5s:1s"]), "outages: expected START:END with START before END"),
    (dict(outages=[(1, 2, 3)]), 'outages: expected "START:END" or (start, end)'),
    (dict(fail_apads=[(7, 60)]), "--fail-apad 7: pool12 has no aPad 7 (its aPads: 1)"),
    (dict(fail_apads=["x:1s"]), "fail_apads: expected SYSID:T"),
    (dict(signing_key=Path("nowhere.key")), "cannot read signing key file nowhere.key"),
    (dict(theta=0.0), "theta: 0.0 is outside"),
    (dict(duration=0), "duration: must be more than 0 s"),
    (dict(seed=-1), "seed: -1 is outside"),
    (dict(resume=True), "nothing to resume: no checkpoint.pkl in any"),
])
def test_a_bad_option_is_a_vil_error_of_one_line_and_nothing_is_made(
    tmp_path: Path, options: dict[str, Any], words: str
) -> None:
    with pytest.raises(vil.Error) as caught:
        vil.run("pool12", **options, out=tmp_path / "runs")
    assert words in str(caught.value) and "\n" not in str(caught.value), str(caught.value)
    assert not (tmp_path / "runs").exists() or not list((tmp_path / "runs").iterdir())


def test_nothing_to_resume_names_the_vil_run_call_that_resumes_what_there_is(tmp_path: Path) -> None:
    folder = RunFolder(tmp_path / "pool12-greedy-seed2-run1")
    folder.path.mkdir()
    folder.checkpoint.write_bytes(b"")  # a run left mid-mission (its content is not read here)
    folder.command.write_text("vil.run(\"pool12.toml\", strategy='greedy', seed=2)\n")
    with pytest.raises(vil.Error) as caught:
        vil.run("pool12", strategy="greedy", out=tmp_path, resume=True)
    assert str(caught.value).endswith(f"{folder.path} holds one: resume it with: "
                                      "vil.run(\"pool12.toml\", strategy='greedy', seed=2, resume=True)")
