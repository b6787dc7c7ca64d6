"""Signing timestamps across restarts: saved atomically, restored with a margin, damaged files survived."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from mavlink_dialect import Codec, mavlink, signing
from mavlink_dialect.signing_state import (
    MAX_FILE_BYTES,
    RESTART_MARGIN_TICKS,
    SigningKeeper,
    SigningState,
    SigningStateError,
    load,
    save,
)

KEY = signing.key_from_passphrase("biograd 2020")
T0 = 300_000_000_000  # MAVLink ticks, some day in 2024


def signed(system_id: int, ticks: int, link_id: int = 1) -> Codec:
    codec = Codec(system_id, 190)
    codec.enable_signing(KEY, link_id, lambda: ticks)
    return codec


def receiver(now: int) -> Codec:
    codec = Codec(1, 1)
    codec.enable_signing(KEY, 0, lambda: now)
    return codec


def heartbeat(codec: Codec) -> bytes:
    return codec.encode(mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_GCS, 8, 0, 0, 4, 3))


def accepted(rx: Codec, frames: list[bytes]) -> int:
    return sum(len(rx.decode(f)) for f in frames)


def test_frames_replayed_after_a_restart_are_refused_and_fresh_ones_taken(tmp_path: Path) -> None:
    path = tmp_path / "apad1.signing.json"
    rx = receiver(T0)
    keeper = SigningKeeper(path, rx.mav, lambda: T0)
    assert keeper.start() is None  # no file yet: nothing to restore
    gcs = signed(250, T0)
    captured = [heartbeat(gcs) for _ in range(14)]
    assert accepted(rx, captured) == 14
    assert keeper.save()

    rx2 = receiver(T0 + 5 * signing.TICKS_PER_S)  # the restarted aPad, 5 s later
    assert SigningKeeper(path, rx2.mav, lambda: T0 + 5 * signing.TICKS_PER_S).start() is None
    assert accepted(rx2, captured) == 0
    assert rx2.signing_refusals == {"replay": 14}
    fresh = signed(250, T0 + RESTART_MARGIN_TICKS + 100)
    assert accepted(rx2, [heartbeat(fresh)]) == 1


def test_without_the_file_a_restart_takes_replays_within_a_minute() -> None:
    """What the file is for: MAVLink lets an unknown stream start up to 60 s behind the clock."""
    gcs = signed(250, T0)
    captured = [heartbeat(gcs) for _ in range(3)]
    assert accepted(receiver(T0), captured) == 3
    assert accepted(receiver(T0 + 30 * signing.TICKS_PER_S), captured) == 3


def test_frames_accepted_after_the_last_save_are_refused_after_a_crash(tmp_path: Path) -> None:
    path = tmp_path / "s.json"
    rx = receiver(T0)
    keeper = SigningKeeper(path, rx.mav, lambda: T0)
    keeper.start()
    gcs = signed(250, T0)
    assert accepted(rx, [heartbeat(gcs)]) == 1
    keeper.save()
    late = signed(250, T0 + signing.TICKS_PER_S)  # accepted a second later, then kill -9: never saved
    unsaved = [heartbeat(late) for _ in range(3)]
    assert accepted(rx, unsaved) == 3
    rx2 = receiver(T0)
    SigningKeeper(path, rx2.mav, lambda: T0).start()
    assert accepted(rx2, unsaved) == 0


def test_the_own_signing_clock_never_goes_backwards_across_a_restart(tmp_path: Path) -> None:
    path = tmp_path / "s.json"
    rx = receiver(T0)
    keeper = SigningKeeper(path, rx.mav, lambda: T0)
    keeper.start()
    before = int.from_bytes(heartbeat(rx)[-12:-6], "little")
    keeper.save()
    wound_back = T0 - 3600 * signing.TICKS_PER_S  # the wall clock was set an hour back before the restart
    rx2 = receiver(wound_back)
    SigningKeeper(path, rx2.mav, lambda: wound_back).start()
    after = int.from_bytes(heartbeat(rx2)[-12:-6], "little")
    assert after > before


def test_the_file_is_replaced_atomically_and_bounded(tmp_path: Path) -> None:
    path = tmp_path / "s.json"
    streams = {(1, sysid, 190): T0 + sysid for sysid in range(1, 65)}
    save(path, SigningState(T0, 7, streams))
    assert [p.name for p in tmp_path.iterdir()] == ["s.json"]  # no temp file left behind
    assert load(path) == SigningState(T0, 7, streams)
    assert path.stat().st_size < MAX_FILE_BYTES


@pytest.mark.parametrize("content", [
    b"\x00\xff garbage",
    b"[]",
    b'{"format": 2, "timestamp": 1, "streams": []}',
    b'{"format": 1, "timestamp": -1, "streams": []}',
    b'{"format": 1, "timestamp": true, "streams": []}',
    b'{"format": 1, "timestamp": 1, "streams": [[1, 300, 1, 5]]}',
    b'{"format": 1, "timestamp": 1, "streams": [[1, 2, 3]]}',
    json.dumps({"format": 1, "timestamp": 1, "streams": [[1, i % 256, i // 256, 5] for i in range(65)]}).encode(),
    b" " * (MAX_FILE_BYTES + 1),
])
def test_a_damaged_file_starts_afresh_refusing_everything_stamped_before_now(tmp_path: Path, content: bytes) -> None:
    path = tmp_path / "apad1.signing.json"
    path.write_bytes(content)
    with pytest.raises(SigningStateError, match=r"apad1\.signing\.json"):
        load(path)
    now = T0 + 10 * signing.TICKS_PER_S
    rx = receiver(now)
    notice = SigningKeeper(path, rx.mav, lambda: now).start()
    assert notice is not None and "\n" not in notice and "starting afresh" in notice
    recorded = heartbeat(signed(250, now - signing.TICKS_PER_S))  # recorded a second before the restart
    assert accepted(rx, [recorded]) == 0
    assert accepted(rx, [heartbeat(signed(250, now + 1))]) == 1
    assert load(path) is not None  # overwritten with a good file


def test_streams_beyond_the_bound_evict_the_stalest_without_reopening_its_replays() -> None:
    rx = receiver(T0)
    first = [heartbeat(signed(sysid, T0 + sysid)) for sysid in range(1, signing.MAX_STREAMS + 1)]
    assert accepted(rx, first) == signing.MAX_STREAMS
    assert accepted(rx, [heartbeat(signed(200, T0 + 500))]) == 1  # one more stream: the stalest (1) goes
    s = rx.mav.signing
    assert len(s.stream_timestamps) == signing.MAX_STREAMS and s.streams_evicted == 1
    assert accepted(rx, [first[0]]) == 0  # its replay is still refused (at or below the floor)
    assert rx.signing_refusals == {"stale_stream": 1}


def test_a_save_the_disk_refuses_is_counted_not_raised(tmp_path: Path) -> None:
    rx = receiver(T0)
    keeper = SigningKeeper(tmp_path / "missing" / "s.json", rx.mav, lambda: T0)
    assert keeper.start() is None
    assert keeper.save_errors == 1
    with pytest.raises(SigningStateError):
        load(tmp_path)  # a directory is not a state file
