"""Codec: real MAVLink 2 frames both ways; garbage and unknown ids are counted, never raised."""

from __future__ import annotations

import copy
import random
import re
import struct
from typing import Any

from mavlink_dialect import Codec, mavlink
from mavlink_dialect import codec as codec_module
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


# ---- the plain path: messages of scalar fields packed and parsed without pymavlink's generic steps ----

PLAIN = sorted(codec_module._PLAIN.values(), key=lambda p: p.msg_id)
_RANGES = {"b": (-128, 127), "B": (0, 255), "h": (-(2**15), 2**15 - 1), "H": (0, 2**16 - 1),
           "i": (-(2**31), 2**31 - 1), "I": (0, 2**32 - 1), "q": (-(2**63), 2**63 - 1), "Q": (0, 2**64 - 1)}


def _draw(plain: codec_module._Plain, rng: random.Random, zeros: float) -> mavlink.MAVLink_message:
    """A message of `plain`'s class with random fields (each 0 with probability `zeros`: cut payloads)."""
    codes = re.findall(r"[a-zA-Z]", plain.unpacker.format)
    wire: dict[str, float] = {}
    for name, code in zip(plain.cls.ordered_fieldnames, codes, strict=True):
        if rng.random() < zeros:
            wire[name] = 0
        elif code in "fd":
            wire[name] = rng.choice([struct.unpack("<f", struct.pack("<f", rng.uniform(-1e6, 1e6)))[0], -0.0, 1.5])
        else:
            wire[name] = rng.randint(*_RANGES[code])
    return plain.cls(**wire)


def _state(msg: mavlink.MAVLink_message) -> tuple[object, ...]:
    m: Any = msg
    fields = tuple(struct.pack("<d", v) if isinstance(v, float) else v for v in (getattr(m, f) for f in m._fieldnames))
    return (type(m), fields, bytes(m._msgbuf), type(m._msgbuf), bytes(m._payload), type(m._payload), m._crc,
            vars(m._header), m._signed, m._link_id)


def test_every_plain_message_packs_and_parses_as_pymavlink_does() -> None:
    assert len(PLAIN) > 100  # the dialect's scalar messages (HEARTBEAT, GLOBAL_POSITION_INT, COMMAND_LONG ...)
    rng = random.Random(7)
    for plain in PLAIN:
        for zeros in (0.0, 0.5, 1.0):
            ours, ref = Codec(rng.randint(1, 255), rng.randint(0, 255)), mavlink.MAVLink(None, 0, 0)
            ref.srcSystem, ref.srcComponent, ref.seq = ours.system_id, ours.component_id, rng.randint(0, 255)
            ours.mav.seq = ref.seq
            msg, twin = _draw(plain, rng, zeros), None
            twin = copy.deepcopy(msg)
            frame = ours.encode(msg)
            assert frame == bytes(twin.pack(ref)), plain.cls.msgname
            assert _state(msg)[2:] == _state(twin)[2:]  # what pack leaves on the message
            rx = Codec(250, 190)
            got = rx.decode(frame)
            assert len(got) == 1 and _state(got[0]) == _state(ref.decode(bytearray(frame))), plain.cls.msgname


def test_a_plain_frame_with_a_broken_crc_or_a_signing_receiver_goes_pymavlinks_way() -> None:
    tx = Codec(1, 1)
    broken = bytearray(tx.encode(mavlink.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3)))
    broken[-2] ^= 0x01
    rx = Codec(250, 190)
    assert rx.decode(bytes(broken)) == [] and rx.stats.bad_data == 1
    strict = Codec(250, 190)
    strict.enable_signing(bytes(32), 0, lambda: 1)
    assert strict.decode(tx.encode(mavlink.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3))) == []  # unsigned: refused
    assert strict.signing_rejects == 1
