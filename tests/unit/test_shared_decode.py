"""hot_decode.SharedDecode: the same datagram objects are decoded once; every party still counts them."""

from __future__ import annotations

import numpy as np
import pytest

from mavlink_dialect import Codec, hot, hot_decode


def _datagrams(n: int = 30) -> list[bytes]:
    fleet = Codec(2, 1)
    frames = hot.encode_batch(fleet, hot.AMUSSEL_STATUS, {
        "time_us": 5, "mussel_id": np.arange(1, n + 1), "lat": 439_390_000 + np.arange(n), "lon": 154_390_000,
        "depth": 1.5, "battery": 0.5, "battery_voltage": 3700, "state": 1, "simulated": 1,
    })
    return [*hot.pack_datagrams(frames), b"\x00garbage"]


def test_same_objects_decoded_once_and_counted_per_party() -> None:
    shared, grams = hot_decode.SharedDecode(), _datagrams()
    a, b = Codec(1, 1), Codec(3, 1)
    first = shared.decode(grams, stats=a.stats)
    second = shared.decode(list(grams), stats=b.stats)  # another list of the very same objects
    assert second is first
    assert a.stats.received == b.stats.received == 30 and a.stats.bad_data == b.stats.bad_data == 1
    plain = hot_decode.decode_datagrams(grams)
    for name, column in plain.hot.fields.items():
        assert np.array_equal(first.hot.fields[name], column)
    with pytest.raises(ValueError):
        first.hot.fields["lat"][0] = 0  # shared: read-only


def test_equal_but_new_objects_and_raw_requests_decode_again() -> None:
    shared, grams = hot_decode.SharedDecode(), _datagrams()
    first = shared.decode(grams)
    assert shared.decode([bytes(bytearray(g)) for g in grams]) is not first
    again = shared.decode(grams)
    with_raw = shared.decode(grams, keep_raw=True)  # a party that logs needs the frames too
    assert with_raw is not again and with_raw.hot.raw is not None and len(with_raw.hot.raw) == 30
    assert shared.decode(grams) is with_raw  # frames kept serve a party that does not need them
