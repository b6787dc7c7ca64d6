"""hot_decode.SharedDecode: the same datagram objects are decoded once; every party still counts them;
datagrams this process packed itself are not parsed at all, and give what parsing them gives."""

from __future__ import annotations

import operator

import numpy as np
import pytest

from mavlink_dialect import Codec, hot, hot_decode, mavlink


def _datagrams(n: int = 30) -> list[bytes]:
    fleet = Codec(2, 1)
    frames = hot.encode_batch(fleet, hot.AMUSSEL_STATUS, {
        "time_us": 5, "mussel_id": np.arange(1, n + 1), "lat": 439_390_000 + np.arange(n), "lon": 154_390_000,
        "depth": 1.5, "battery": 0.5, "battery_voltage": 3700, "state": 1, "simulated": 1,
    })
    # Copies, as a socket delivers them: not the objects this process packed (see the last tests).
    return [*(bytes(bytearray(d)) for d in hot.pack_datagrams(frames)), b"\x00garbage"]


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


def _statuses(n: int, seq: int = 250) -> tuple[list[bytes], list[bytes]]:
    """A fleet's batch as this process packs it: (frames, datagrams)."""
    fleet = Codec(251, 25)
    fleet.mav.seq = seq
    frames = hot.encode_batch(fleet, hot.AMUSSEL_STATUS, {
        "time_us": 7, "mussel_id": np.arange(1, n + 1), "lat": 439_390_000 - np.arange(n), "lon": 154_390_000,
        "depth": np.linspace(0.0, 3.0, n), "battery": np.linspace(0.1, 1.0, n), "battery_voltage": 3900,
        "state": np.arange(n) % 6, "simulated": 1,
    })
    return frames, hot.pack_datagrams(frames, max_bytes=400)


def _same(a: hot_decode.Split, b: hot_decode.Split) -> None:
    assert a.bad == b.bad and a.others == b.others and a.hot.raw == b.hot.raw
    for name, column in b.hot.fields.items():
        assert a.hot.fields[name].dtype == column.dtype and a.hot.fields[name].tobytes() == column.tobytes()
    for got, want in ((a.hot.src_system, b.hot.src_system), (a.hot.src_component, b.hot.src_component),
                      (a.hot.seq, b.hot.seq)):
        assert got.dtype == want.dtype and np.array_equal(got, want)


@pytest.mark.parametrize("n", [12, 120])  # the struct path and the numpy path of the encoder
def test_the_datagrams_packed_here_give_their_records_as_parsing_would(n: int) -> None:
    heartbeat = Codec(250, 190).encode(mavlink.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3))
    frames, grams = _statuses(n)
    assert len(grams) > 1
    received = [heartbeat, *grams, heartbeat]  # as an aPad's inbox holds them: the batch among others
    stats = Codec(1, 1).stats
    got = hot_decode.SharedDecode().decode(received, stats=stats, keep_raw=True)
    assert got.hot.raw is not None and all(map(operator.is_, got.hot.raw, frames))  # taken, not parsed
    _same(got, hot_decode.decode_datagrams([bytes(bytearray(d)) for d in received], keep_raw=True))
    assert (stats.received, stats.bad_data) == (n, 0)


def test_a_broken_run_or_more_statuses_beside_it_are_parsed() -> None:
    _, other = _statuses(3, seq=0)  # another batch, packed before: not the last one
    frames, grams = _statuses(30)
    for received in (grams[1:], [*other, *grams]):
        got = hot_decode.SharedDecode().decode(received, keep_raw=True)
        assert got.hot.raw is not None and not any(map(operator.is_, got.hot.raw, frames))
        _same(got, hot_decode.decode_datagrams(received, keep_raw=True))
