"""MAVLink 2 message signing: the shared key, and signing timestamps from any clock.

The key is sha256 of a passphrase (MAVProxy's convention), read from a file or from the
environment variable `VIL_SIGNING_KEY`. Timestamps are MAVLink's: 10 µs units since
2015-01-01 00:00 UTC. They come from a callable the owner supplies (mission time plus the
run's epoch), never from `time.time()`, so lockstep runs sign deterministically; pymavlink then
adds one per packet. A receiver with the key rejects unsigned, wrongly signed and replayed
(timestamp not newer than that stream's last) frames; `Codec` counts them as bad data, and by
reason in `Codec.signing_refusals`.

Streams are (link id, system, component). At most `MAX_STREAMS` are remembered: a new one beyond
that evicts the stalest, whose timestamp becomes a floor no unknown stream may stamp at or below,
so eviction never reopens a replay. `mavlink_dialect.signing_state` keeps the table across restarts.
"""

from __future__ import annotations

import hashlib
import hmac
import os
import struct
import types
from collections import Counter
from collections.abc import Callable, Collection
from pathlib import Path
from typing import Any

KEY_ENV = "VIL_SIGNING_KEY"
KEY_LEN = 32
MAVLINK_EPOCH_US = 1_420_070_400_000_000  # 2015-01-01 00:00 UTC
US_PER_TICK = 10
TICKS_PER_S = 1_000_000 // US_PER_TICK
NEW_STREAM_WINDOW_TICKS = 60 * TICKS_PER_S  # a stream never seen may start this far behind our clock
MAX_STREAMS = 64  # signed streams remembered; only a key holder can make one


class SigningKeyError(ValueError):
    """A key file that cannot be read or is empty; the message is one line."""


def key_from_passphrase(passphrase: str) -> bytes:
    return hashlib.sha256(passphrase.encode("utf-8")).digest()


def load_key(path: Path | None = None, environ: dict[str, str] | None = None) -> bytes | None:
    """The signing key from `path` (its first line is the passphrase), else from VIL_SIGNING_KEY; None: off."""
    if path is not None:
        try:
            passphrase = path.read_text(encoding="utf-8").strip().splitlines()
        except (OSError, UnicodeDecodeError) as exc:
            why = getattr(exc, "strerror", None) or exc
            raise SigningKeyError(f"cannot read signing key file {path}: {why}") from None
        if not passphrase or not passphrase[0].strip():
            raise SigningKeyError(f"signing key file {path} is empty")
        return key_from_passphrase(passphrase[0].strip())
    env = os.environ if environ is None else environ
    value = env.get(KEY_ENV, "").strip()
    return key_from_passphrase(value) if value else None


def timestamp_ticks(epoch_us: int, now_us: int) -> int:
    """MAVLink signing timestamp for mission time `now_us` of a run whose t = 0 is `epoch_us` (Unix µs)."""
    return max(epoch_us + now_us - MAVLINK_EPOCH_US, 0) // US_PER_TICK


def configure(
    mav: Any,
    key: bytes,
    link_id: int,
    allow_unsigned_ids: Collection[int] = (),
) -> None:
    """Sign everything `mav` sends and accept only frames signed with `key`, except the message ids listed."""
    if len(key) != KEY_LEN:
        raise ValueError(f"a MAVLink signing key is {KEY_LEN} bytes, got {len(key)}")
    allowed = frozenset(allow_unsigned_ids)
    mav.signing.secret_key = key
    mav.signing.sign_outgoing = True
    mav.signing.link_id = link_id
    # Always a callback, so pymavlink counts every refusal (unsigned, forged, replayed) in reject_count.
    mav.signing.allow_unsigned_callback = lambda _mav, msg_id: msg_id in allowed
    mav.signing.refused = Counter()  # signed frames refused, by reason (unsigned ones: reject_count)
    mav.signing.stream_floor = 0  # unknown streams must stamp above this (raised by eviction, restarts)
    mav.signing.streams_evicted = 0  # MAX_STREAMS was hit this often
    mav.check_signature = types.MethodType(_check_signature, mav)


_STAMP = struct.Struct("<IH")


def _check_signature(mav: Any, msgbuf: bytearray, src_system: int, src_component: int) -> bool:
    """pymavlink's check, with the signature verified *before* the stream's timestamp is advanced.

    pymavlink 2.4.50 records a frame's timestamp first: one forged frame stamped in the future would
    make every genuine frame of that stream look like a replay until the clock caught up.
    """
    s = mav.signing
    low, high = _STAMP.unpack(msgbuf[-12:-6])
    timestamp = low + (high << 32)
    stream = (msgbuf[-13], src_system, src_component)
    last = s.stream_timestamps.get(stream)
    if last is not None and timestamp <= last:
        s.refused["replay"] += 1  # replayed or reordered
        return False
    if last is None and (timestamp + NEW_STREAM_WINDOW_TICKS < s.timestamp or timestamp <= s.stream_floor):
        s.refused["stale_stream"] += 1  # a "new" stream more than a minute old, or from before a restart
        return False
    digest = hashlib.sha256(s.secret_key + bytes(msgbuf[:-6])).digest()[:6]
    if not hmac.compare_digest(digest, bytes(msgbuf[-6:])):
        s.refused["bad_signature"] += 1
        return False
    if last is None and len(s.stream_timestamps) >= MAX_STREAMS:
        evict_stalest(s)
    s.stream_timestamps[stream] = timestamp
    s.timestamp = max(s.timestamp, timestamp)
    return True


def evict_stalest(s: Any) -> None:
    """Forget the stream with the oldest timestamp; it becomes the floor for unknown streams."""
    stalest = min(s.stream_timestamps, key=s.stream_timestamps.__getitem__)
    s.stream_floor = max(s.stream_floor, s.stream_timestamps.pop(stalest))
    s.streams_evicted += 1


TicksFn = Callable[[], int]
