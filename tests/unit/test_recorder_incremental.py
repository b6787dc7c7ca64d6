"""Incremental checkpoints of the recorder: its rows in pieces, decimation, the side files, damage."""

from __future__ import annotations

import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from gcs.mission.checkpoint import Checkpoint, CheckpointError, CheckpointFiles, load, save
from mussel_sim.fleet_state import ACTIVE, SURFACING, FleetParams, FleetState, state_from_arrays
from mussel_sim.recorder import Recorder, RecorderRows

N = 7
ROW_BYTES = N * 5  # one trace row: battery float32 and state uint8 per aMussel


def states(steps: int, seed: int = 0) -> list[FleetState]:
    """`steps` fleet states at 1 s apart, with batteries and active counts that vary step to step."""
    rng = np.random.default_rng(seed)
    ids = np.arange(1, N + 1)
    base = state_from_arrays(ids, 10.0 * ids, np.zeros(N), np.full(N, 0.9), FleetParams())
    out = []
    for k in range(steps):
        active = rng.random(N) < 0.7
        out.append(replace(base, time_us=(k + 1) * 1_000_000, battery_frac=rng.random(N),
                           state=np.where(active, ACTIVE, SURFACING).astype(base.state.dtype)))
    return out


def assert_same(a: Recorder, b: Recorder) -> None:
    np.testing.assert_array_equal(a.uptime_pct(), b.uptime_pct())
    np.testing.assert_array_equal(a.active_count(), b.active_count())
    np.testing.assert_array_equal(a.step_time_us(), b.step_time_us())
    sa, ta = a.battery_trace()
    sb, tb = b.battery_trace()
    np.testing.assert_array_equal(sa, sb)
    np.testing.assert_array_equal(ta, tb)
    np.testing.assert_array_equal(a.state_trace()[1], b.state_trace()[1])
    assert a.days == b.days
    assert a.summary() == b.summary()
    assert a.trace_stride == b.trace_stride
    assert a.start_us == b.start_us


def concat(pieces: list[RecorderRows]) -> RecorderRows:
    return RecorderRows(*(np.concatenate([getattr(p, f) for p in pieces])
                          for f in ("time_us", "active_count", "trace_steps", "trace", "trace_state")))


# --- the recorder's own split ------------------------------------------------------------------------


@pytest.mark.parametrize("budget_rows", [10**6, 16, 5])
def test_rows_taken_in_pieces_rebuild_the_same_recorder_and_it_goes_on_the_same(budget_rows: int) -> None:
    run = states(400)
    # A first step shorter than the others (0.6 s): the start is kept, not guessed from the steps.
    rec = Recorder(np.arange(1, N + 1), max_trace_bytes=budget_rows * ROW_BYTES, day_us=7_000_000, start_us=400_000)
    pieces, done = [], 0
    for k, s in enumerate(run[:300]):
        rec.record(s)
        if k % 7 == 3:  # a checkpoint now and then: only what is new since the last one
            pieces.append(rec.rows_since(done))
            done = rec.n_steps
    pieces.append(rec.rows_since(done))
    rows = concat(pieces)
    assert rows.time_us.size == 300  # every step exactly once
    if budget_rows < 300:  # decimated: the pieces hold rows the recorder has dropped since
        assert rec.trace_stride > 1 and rows.trace_steps.size > len(rec.battery_trace()[0])
    back = Recorder.restore(rec.head(), rows)
    assert_same(back, rec)
    for s in run[300:]:  # the restored one records on exactly as the original
        rec.record(s)
        back.record(s)
    assert_same(back, rec)


def test_decimation_keeps_the_steps_of_the_stride_and_restore_drops_the_rest() -> None:
    rec = Recorder(np.arange(1, N + 1), max_trace_bytes=8 * ROW_BYTES)
    run = states(50)
    for s in run[:20]:
        rec.record(s)
    early = rec.rows_since(0)
    for s in run[20:]:
        rec.record(s)
    steps, trace = rec.battery_trace()
    assert rec.trace_stride == 8 and steps.tolist() == [0, 8, 16, 24, 32, 40, 48]
    np.testing.assert_array_equal(trace[1], run[8].battery_frac.astype(np.float32))
    # The early piece was taken at stride 4 (steps 0, 4, ..., 16); restore must drop 4 and 12.
    late = rec.rows_since(20)
    assert early.trace_steps.tolist() == [0, 4, 8, 12, 16] and late.trace_steps.tolist() == [24, 32, 40, 48]
    assert_same(Recorder.restore(rec.head(), concat([early, late])), rec)


def test_traces_off_and_selected_traces_survive_the_split() -> None:
    run = states(30)
    for rec in (Recorder(np.arange(1, N + 1), trace_every_steps=0), Recorder(np.arange(1, N + 1), trace_ids=[2, 6])):
        for s in run:
            rec.record(s)
        assert_same(Recorder.restore(rec.head(), rec.rows_since(0)), rec)


def test_restore_refuses_rows_that_do_not_fit_the_head() -> None:
    rec = Recorder(np.arange(1, N + 1))
    for s in states(10):
        rec.record(s)
    rows = rec.rows_since(0)
    with pytest.raises(ValueError, match="step rows"):
        Recorder.restore(rec.head(), rec.rows_since(1))
    with pytest.raises(ValueError, match="step order"):
        Recorder.restore(rec.head(), replace(rows, trace_steps=rows.trace_steps[::-1].copy()))
    with pytest.raises(ValueError, match="traced"):
        Recorder.restore(rec.head(), replace(rows, trace=rows.trace[:, :3]))
    with pytest.raises(ValueError, match="outside"):
        rec.rows_since(11)


# --- the side files -----------------------------------------------------------------------------------


def checkpoint_of(rec: Recorder) -> Checkpoint:
    """A checkpoint whose only real part is the recorder (the rest is carried as it is)."""
    last = rec.step_time_us()[-1] if rec.n_steps else 0
    return Checkpoint(2, ("test", "greedy", 1), int(last), None, {"rng": 1}, rec, {1: "loop"},  # type: ignore[arg-type,dict-item]
                      "registry", {}, None, frozenset(), {}, "", "")  # type: ignore[arg-type]


def test_saved_every_few_steps_with_decimation_the_checkpoint_loads_the_same_recorder(tmp_path: Path) -> None:
    path = tmp_path / "checkpoint.pkl"
    files = CheckpointFiles(path)
    rec = Recorder(np.arange(1, N + 1), max_trace_bytes=6 * ROW_BYTES)
    for k, s in enumerate(states(200)):
        rec.record(s)
        if k % 10 == 9:
            save(files, checkpoint_of(rec))
    files.close()
    assert rec.trace_stride >= 32
    ckpt = load(path)
    assert_same(ckpt.recorder, rec)
    assert (ckpt.run_key, ckpt.time_us, ckpt.fleet_rng_state, ckpt.loop_statuses) == (
        ("test", "greedy", 1), 200_000_000, {"rng": 1}, {1: "loop"})
    # Append-only: the trace file holds every row ever kept at the time, more than the recorder now has.
    rows_on_disk = (files.traces_path.stat().st_size - 16) // (8 + ROW_BYTES)
    assert rows_on_disk > len(rec.battery_trace()[0])


def test_a_crash_between_the_rows_and_the_small_file_then_a_resume(tmp_path: Path) -> None:
    path = tmp_path / "checkpoint.pkl"
    run = states(300)
    whole = Recorder(np.arange(1, N + 1), max_trace_bytes=9 * ROW_BYTES)  # never crashed
    for s in run:
        whole.record(s)

    files = CheckpointFiles(path)
    rec = Recorder(np.arange(1, N + 1), max_trace_bytes=9 * ROW_BYTES)
    for s in run[:100]:
        rec.record(s)
    save(files, checkpoint_of(rec))
    small_at_100 = path.read_bytes()
    for s in run[100:150]:
        rec.record(s)
    save(files, checkpoint_of(rec))
    files.close()
    path.write_bytes(small_at_100)  # as if killed after appending the rows of step 150, before os.replace
    steps_size = files.steps_path.stat().st_size

    again = CheckpointFiles(path)
    ckpt = load(again)
    assert ckpt.recorder.n_steps == 100  # the rows past what the small file vouches for are ignored
    back = ckpt.recorder
    for k, s in enumerate(run[100:], start=100):  # the mission is simulated again from step 100
        back.record(s)
        if k % 20 == 19:
            save(again, checkpoint_of(back))
    again.close()
    assert files.steps_path.stat().st_size == 16 + 300 * 12 < steps_size + 200 * 12  # stale rows cut, not kept
    assert_same(back, whole)
    assert_same(load(path).recorder, whole)


def damaged(tmp_path: Path) -> CheckpointFiles:
    files = CheckpointFiles(tmp_path / "checkpoint.pkl")
    rec = Recorder(np.arange(1, N + 1))
    for s in states(40):
        rec.record(s)
        if rec.n_steps % 10 == 0:
            save(files, checkpoint_of(rec))
    files.close()
    assert_same(load(files.path).recorder, rec)  # intact before the damage
    return files


def flip(path: Path, at: int) -> None:
    data = bytearray(path.read_bytes())
    data[at] ^= 0x5A
    path.write_bytes(bytes(data))


@pytest.mark.parametrize("damage, message", [
    (lambda f: f.steps_path.unlink(), "missing"),
    (lambda f: f.traces_path.unlink(), "missing"),
    (lambda f: f.steps_path.write_bytes(f.steps_path.read_bytes()[:-5]), "truncated"),
    (lambda f: f.traces_path.write_bytes(f.traces_path.read_bytes()[:100]), "truncated"),
    (lambda f: f.traces_path.write_bytes(b""), "bad header"),
    (lambda f: flip(f.steps_path, 3), "bad header"),
    (lambda f: flip(f.steps_path, 16 + 12 * 20 + 2), "corrupt"),
    (lambda f: flip(f.traces_path, f.traces_path.stat().st_size - 1), "corrupt"),
    (lambda f: shutil.copy(f.traces_path, f.steps_path), "bad header"),
    (lambda f: f.path.write_bytes(f.path.read_bytes()[:-30]), "cannot read checkpoint"),
    (lambda f: f.path.write_bytes(b"garbage" * 20), "cannot read checkpoint"),
    (lambda f: f.path.unlink(), "no checkpoint to resume from"),
])
def test_a_damaged_checkpoint_is_one_line_of_checkpoint_error(tmp_path: Path, damage, message: str) -> None:  # type: ignore[no-untyped-def]
    files = damaged(tmp_path)
    damage(files)
    with pytest.raises(CheckpointError, match=message) as err:
        load(files.path)
    assert "\n" not in str(err.value)


def test_rows_appended_past_the_checkpoint_are_no_damage(tmp_path: Path) -> None:
    files = damaged(tmp_path)
    with files.steps_path.open("ab") as f:
        f.write(b"\x01" * 17)  # a half-written record after the valid ones
    with files.traces_path.open("ab") as f:
        f.write(b"\x02" * 1000)
    assert load(files.path).recorder.n_steps == 40


def test_a_finished_run_removes_all_its_checkpoint_files(tmp_path: Path) -> None:
    files = damaged(tmp_path)
    assert {p.name for p in tmp_path.iterdir()} == {"checkpoint.pkl", "checkpoint.steps", "checkpoint.traces"}
    files.remove()
    assert list(tmp_path.iterdir()) == []


def test_a_new_run_does_not_mix_with_an_older_checkpoint_in_its_folder(tmp_path: Path) -> None:
    old = damaged(tmp_path)
    new = CheckpointFiles(old.path)  # not resumed: starts its own side files
    rec = Recorder(np.arange(1, N + 1))
    rec.record(states(1)[0])
    save(new, checkpoint_of(rec))
    new.close()
    assert load(old.path).recorder.n_steps == 1


def test_a_new_run_that_dies_before_its_first_checkpoint_leaves_none(tmp_path: Path) -> None:
    old = damaged(tmp_path)
    new = CheckpointFiles(old.path)
    rec = Recorder(np.arange(1, N + 1))
    rec.record(states(1)[0])
    (tmp_path / "checkpoint.pkl.tmp").mkdir()  # the small file cannot be written: as if killed before it
    with pytest.raises(OSError):
        save(new, checkpoint_of(rec))
    new.close()
    with pytest.raises(CheckpointError, match="no checkpoint to resume from"):
        load(old.path)
