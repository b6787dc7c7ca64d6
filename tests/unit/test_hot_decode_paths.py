"""hot_decode.decode_datagrams checks few hot frames in Python and many with numpy: both give the same split."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mavlink_dialect import Codec, hot, hot_decode, mavlink


def _statuses(n: int, seed: int) -> list[bytes]:
    rng = np.random.default_rng(seed)
    return hot.encode_batch(Codec(2, 1), hot.AMUSSEL_STATUS, {
        "time_us": int(rng.integers(0, 2**40)), "mussel_id": rng.integers(1, 2**16, n),
        "lat": rng.integers(-2**31, 2**31, n), "lon": rng.integers(-2**31, 2**31, n),
        "depth": rng.uniform(0, 3, n), "battery": rng.uniform(0, 1, n),
        "battery_voltage": rng.integers(0, 2**16, n), "state": rng.integers(0, 6, n),
        "simulated": rng.integers(0, 2, n),
    })


def _both(grams: list[bytes], keep_raw: bool) -> tuple[hot_decode.Split, hot_decode.Split]:
    splits = []
    for few in (0, 10**9):  # every batch the numpy way, then every batch the Python way
        old, hot_decode.FEW_FRAMES = hot_decode.FEW_FRAMES, few
        try:
            splits.append(hot_decode.decode_datagrams(grams, keep_raw=keep_raw))
        finally:
            hot_decode.FEW_FRAMES = old
    return splits[0], splits[1]


@settings(max_examples=60, deadline=None)
@given(n=st.integers(0, 80), seed=st.integers(0, 10**6),
       cuts=st.lists(st.tuples(st.integers(0, 10**6), st.integers(0, 255)), max_size=6), keep_raw=st.booleans())
def test_python_and_numpy_checks_agree(n: int, seed: int, cuts: list[tuple[int, int]], keep_raw: bool) -> None:
    frames = _statuses(n, seed)
    hb = Codec(1, 1).encode(mavlink.MAVLink_heartbeat_message(10, 3, 0, 0, 4, 3))
    grams = [bytearray(g) for g in hot.pack_datagrams([*frames[: n // 2], hb, *frames[n // 2:]])]
    for where, value in cuts:  # flipped bytes: CRC failures, lengths that run off, garbage
        g = grams[where % len(grams)]
        g[where % len(g)] = value
    a, b = _both([bytes(g) for g in grams], keep_raw)
    assert (a.bad, a.others, a.hot.raw) == (b.bad, b.others, b.hot.raw)
    for name in hot.AMUSSEL_STATUS.fieldnames:
        assert a.hot.fields[name].dtype == b.hot.fields[name].dtype
        assert a.hot.fields[name].tobytes() == b.hot.fields[name].tobytes()
    for column in ("src_system", "src_component", "seq"):
        x, y = getattr(a.hot, column), getattr(b.hot, column)
        assert x.dtype == y.dtype == np.uint8 and np.array_equal(x, y)


@pytest.mark.parametrize("length", [0, 1, 20, 37, 60])
def test_short_and_long_payloads_agree(length: int) -> None:
    frame = bytearray(_statuses(1, 3)[0])
    payload = bytes(frame[10:-2]).ljust(length, b"\x07")[:length]
    body = bytes([0xFD, length]) + bytes(frame[2:10]) + payload
    crc = mavlink.x25crc(body[1:])
    crc.accumulate(bytes([hot.AMUSSEL_STATUS.crc_extra]))
    a, b = _both([body + crc.crc.to_bytes(2, "little")], keep_raw=True)
    assert len(a.hot) == len(b.hot) == 1
    assert a.hot.fields["lat"].tobytes() == b.hot.fields["lat"].tobytes() and a.hot.raw == b.hot.raw
    assert all(b.hot.fields[f].flags.writeable for f in hot.AMUSSEL_STATUS.fieldnames)
