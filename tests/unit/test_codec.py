"""Codec: real MAVLink 2 frames both ways; garbage and unknown ids are counted, never raised."""

from __future__ import annotations

from mavlink_dialect import Codec, mavlink
from mussel_sim.vocabulary import MusselState


def status(mussel_id: int = 24) -> mavlink.MAVLink_amussel_status_message:
    return mavlink.MAVLink_amussel_status_message(
        123, mussel_id, 439400000, 154400000, 2.5, 0.75, 4050, MusselState.ACTIVE, 1
    )


def test_round_trip_keeps_fields_ids_and_sequence() -> None:
    tx, rx = Codec(251, 25), Codec(250, 190)
    frames = [tx.encode(status(i)) for i in (1, 2, 3)]
    assert all(f[0] == 0xFD for f in frames)  # MAVLink 2 magic
    msgs = rx.decode(b"".join(frames))
    assert [m.mussel_id for m in msgs] == [1, 2, 3]
    assert [m.get_seq() for m in msgs] == [0, 1, 2]
    assert (msgs[0].get_srcSystem(), msgs[0].get_srcComponent()) == (251, 25)
    assert msgs[0].lat == 439400000 and abs(msgs[0].battery - 0.75) < 1e-7
    assert rx.stats.received == 3 and rx.stats.bad_data == 0


def test_stream_split_at_every_byte_still_parses() -> None:
    tx, rx = Codec(1, 1), Codec(250, 190)
    frame = tx.encode(status())
    got = []
    for i in range(len(frame)):
        got += rx.decode(frame[i : i + 1])
    assert [m.mussel_id for m in got] == [24]


def test_garbage_and_broken_crc_are_counted_and_dropped() -> None:
    tx, rx = Codec(1, 1), Codec(250, 190)
    good = tx.encode(status(7))
    broken = bytearray(tx.encode(status(8)))
    broken[-1] ^= 0xFF  # CRC byte
    msgs = rx.decode(b"\x00\x01garbage" + bytes(broken) + good)
    assert [m.mussel_id for m in msgs] == [7]
    assert rx.stats.bad_data >= 2


def test_unknown_message_id_is_counted_as_unknown() -> None:
    tx, rx = Codec(1, 1), Codec(250, 190)
    frame = bytearray(tx.encode(status()))
    frame[7:10] = (54099).to_bytes(3, "little")  # an id nobody defines
    msgs = rx.decode(bytes(frame))
    assert msgs == []
    assert (rx.stats.unknown, rx.stats.bad_data) == (1, 0)


def test_one_broken_frame_per_datagram_is_counted_and_the_next_still_parses() -> None:
    tx, rx = Codec(1, 1), Codec(250, 190)
    broken = bytearray(tx.encode(status(8)))
    broken[12] ^= 0x55  # payload byte: CRC no longer matches
    assert rx.decode(bytes(broken)) == []
    assert rx.stats.bad_data == 1
    assert [m.mussel_id for m in rx.decode(tx.encode(status(9)))] == [9]
