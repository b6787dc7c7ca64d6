"""The batch path (mavlink_dialect.hot) against pymavlink: same bytes out, same values in, same refusals."""

from __future__ import annotations

import math
import struct
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from mavlink_dialect import Codec, hot, mavlink
from mavlink_dialect.hot import AMUSSEL_SENSORS, AMUSSEL_STATUS, HotSpec, encode_batch, pack_datagrams
from mavlink_dialect.hot_decode import HotFrames, decode_datagram, decode_datagrams
from mavlink_dialect.tlog import TlogWriter, frames

SPECS = [AMUSSEL_STATUS, AMUSSEL_SENSORS]
F32_MAX = float(np.finfo(np.float32).max)
KEY = bytes(range(32))
Row = dict[str, Any]


def _bits_to_float(bits: int) -> float:
    return float(struct.unpack("<d", struct.pack("<Q", bits))[0])


def _nans() -> st.SearchStrategy[float]:
    """NaNs of either sign with any payload (quiet or signalling), as a float64 carries them."""
    return st.builds(
        lambda sign, mantissa: _bits_to_float(sign << 63 | 0x7FF << 52 | (mantissa or 1)),
        st.integers(0, 1),
        st.integers(0, (1 << 52) - 1),
    )


def _field(spec: HotSpec, name: str) -> st.SearchStrategy[Any]:
    dtype = spec.dtype.fields[name][0]  # type: ignore[index]
    if dtype.kind == "f":
        specials = st.sampled_from([0.0, -0.0, math.nan, math.inf, -math.inf, F32_MAX, -F32_MAX, 1e-45])
        return st.one_of(specials, _nans(), st.floats(width=32), st.floats(-F32_MAX, F32_MAX))
    info = np.iinfo(dtype)
    return st.one_of(st.sampled_from([0, int(info.min), int(info.max)]), st.integers(int(info.min), int(info.max)))


def _rows(spec: HotSpec, max_size: int = 40) -> st.SearchStrategy[list[Row]]:
    row = st.fixed_dictionaries({f: _field(spec, f) for f in spec.fieldnames})
    return st.lists(row, min_size=1, max_size=max_size)


def _columns(spec: HotSpec, rows: list[Row]) -> dict[str, np.ndarray]:
    """Rows as the (n,) arrays a fleet would hold: integers in their own type, floats as float64."""
    out = {}
    for f in spec.fieldnames:
        dtype = spec.dtype.fields[f][0]  # type: ignore[index]
        out[f] = np.array([r[f] for r in rows], np.float64 if dtype.kind == "f" else dtype)
    return out


def _wire(spec: HotSpec, name: str, value: Any) -> Any:
    """A field value as it is on the wire: float fields by their float32 bits (NaN == NaN, -0.0 != 0.0)."""
    if spec.dtype.fields[name][0].kind == "f":  # type: ignore[index]
        return struct.pack("<f", value)
    return int(value)


def _hot_rows(spec: HotSpec, hot: HotFrames) -> list[tuple[Any, ...]]:
    return [
        (int(hot.src_system[i]), int(hot.src_component[i]), int(hot.seq[i]),
         *(_wire(spec, f, hot.fields[f][i]) for f in spec.fieldnames))
        for i in range(len(hot))
    ]  # fmt: skip


def _msg_rows(spec: HotSpec, msgs: list[mavlink.MAVLink_message]) -> list[tuple[Any, ...]]:
    return [
        (m.get_srcSystem(), m.get_srcComponent(), m.get_seq(),
         *(_wire(spec, f, getattr(m, f)) for f in spec.fieldnames))
        for m in msgs
    ]  # fmt: skip


@contextmanager
def _path(few_rows: int) -> Iterator[None]:
    """Encode on the struct path (hot.FEW_ROWS as it is: the batches here are small) or the numpy one (0)."""
    kept, hot.FEW_ROWS = hot.FEW_ROWS, few_rows
    try:
        yield
    finally:
        hot.FEW_ROWS = kept


PATHS = pytest.mark.parametrize("few_rows", [hot.FEW_ROWS, 0], ids=["struct", "numpy"])


def _pair(system: int, component: int, seq: int) -> tuple[Codec, Codec]:
    """Two identical senders: one for the batch path, one for pymavlink's."""
    a, b = Codec(system, component), Codec(system, component)
    a.mav.seq = b.mav.seq = seq
    return a, b


def _status(i: int) -> Row:
    return dict(time_us=i * 1000, mussel_id=i + 1, lat=439400000 + i, lon=154400000 - i, depth=2.5, battery=0.75,
                battery_voltage=4050, state=2, simulated=1)  # fmt: skip


HEARTBEAT = mavlink.MAVLink_heartbeat_message(11, 3, 0, 4, 4, 3)


# ---- encode -------------------------------------------------------------------------------------


@PATHS
@pytest.mark.parametrize("spec", SPECS, ids=lambda s: s.name)
@settings(max_examples=80, deadline=None)  # per path: the two together about what one path had
@given(data=st.data(), system=st.integers(1, 255), component=st.integers(0, 255), seq=st.integers(0, 255))
def test_batch_frames_are_byte_identical_to_codec_encode(
    spec: HotSpec, data: st.DataObject, system: int, component: int, seq: int, few_rows: int
) -> None:
    rows = data.draw(_rows(spec))
    batch, ref = _pair(system, component, seq)
    with _path(few_rows):
        got = encode_batch(batch, spec, _columns(spec, rows))
    want = [ref.encode(spec.cls(**r)) for r in rows]
    assert got == want
    assert (batch.mav.seq, batch.stats.sent) == (ref.mav.seq, len(rows))
    decoded = Codec(250, 190).decode(b"".join(got))
    assert _msg_rows(spec, decoded) == [
        (system, component, (seq + i) % 256, *(_wire(spec, f, r[f]) for f in spec.fieldnames))
        for i, r in enumerate(rows)
    ]


def test_sequence_numbers_wrap_and_continue_the_codecs_own() -> None:
    batch, ref = _pair(7, 1, 250)
    ref.encode(HEARTBEAT), batch.encode(HEARTBEAT)  # the codec's own frames and batch ones share one run
    rows = [_status(i) for i in range(10)]
    got = encode_batch(batch, AMUSSEL_STATUS, _columns(AMUSSEL_STATUS, rows))
    assert [f[4] for f in got] == [251, 252, 253, 254, 255, 0, 1, 2, 3, 4]
    assert got == [ref.encode(mavlink.MAVLink_amussel_status_message(**r)) for r in rows]
    assert batch.encode(HEARTBEAT) == ref.encode(HEARTBEAT)


def test_all_zero_payload_keeps_one_byte_and_trailing_zeros_go() -> None:
    zero = {f: np.zeros(2) if f in ("depth", "battery") else np.zeros(2, int) for f in AMUSSEL_STATUS.fieldnames}
    zero["time_us"] = np.array([0, 1])
    batch, ref = _pair(1, 1, 0)
    got = encode_batch(batch, AMUSSEL_STATUS, zero)
    want = [mavlink.MAVLink_amussel_status_message(**{f: zero[f][i].item() for f in zero}) for i in (0, 1)]
    assert got == [ref.encode(m) for m in want]
    assert [f[1] for f in got] == [1, 1]  # payload length byte
    assert [len(f) for f in got] == [13, 13]


@PATHS
@settings(max_examples=150, deadline=None)
@given(value=st.floats(allow_nan=True, allow_infinity=True) | st.integers(-(2**1100), 2**1100))
@example(value=3.4028235677973366e38)  # halfway past FLT_MAX: rounds to inf, struct refuses
@example(value=float(np.nextafter(3.4028235677973366e38, 0)))  # just below: rounds to FLT_MAX
@example(value=2**128)
def test_float_fields_refuse_exactly_what_struct_refuses(value: float, few_rows: int) -> None:
    cols = _columns(AMUSSEL_STATUS, [_status(0)])
    cols["depth"] = np.array([value], object if isinstance(value, int) and abs(value) >= 2**63 else None)
    try:
        want = Codec(1, 1).encode(mavlink.MAVLink_amussel_status_message(**{**_status(0), "depth": value}))
    except (OverflowError, struct.error):
        with _path(few_rows), pytest.raises(ValueError, match="depth"):
            encode_batch(Codec(1, 1), AMUSSEL_STATUS, cols)
    else:
        with _path(few_rows):
            assert encode_batch(Codec(1, 1), AMUSSEL_STATUS, cols) == [want]


@PATHS
@pytest.mark.parametrize("same_value_cast", [True, False], ids=["numpy-2.4-cast", "min-max"])
@pytest.mark.parametrize(
    ("field", "value"),
    [("mussel_id", 65536), ("mussel_id", -1), ("lat", 2**31), ("lat", -(2**31) - 1), ("state", 256),
     ("time_us", 2**64), ("time_us", -1)],
)  # fmt: skip
def test_out_of_range_integers_raise_naming_the_field_and_take_no_sequence_numbers(
    field: str, value: int, same_value_cast: bool, few_rows: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(hot, "_SAME_VALUE", same_value_cast and hot._SAME_VALUE)
    monkeypatch.setattr(hot, "FEW_ROWS", few_rows)
    with pytest.raises(struct.error):  # what pymavlink does with the same value
        mavlink.MAVLink_amussel_status_message(**{**_status(0), field: value}).pack(Codec(1, 1).mav)
    codec = Codec(1, 1)
    cols: dict[str, Any] = _columns(AMUSSEL_STATUS, [_status(0), _status(1)])
    cols[field] = np.array([1, value], dtype=np.int64 if abs(value) < 2**63 else object)
    with pytest.raises(ValueError, match=field):
        encode_batch(codec, AMUSSEL_STATUS, cols)
    assert (codec.mav.seq, codec.stats.sent) == (0, 0)
    edge = value - 1 if value > 0 else value + 1  # the last value that fits packs as pymavlink packs it
    cols[field] = np.array([1, edge], dtype=np.int64 if abs(edge) < 2**63 else np.uint64)
    ref = Codec(1, 1)
    msgs = [mavlink.MAVLink_amussel_status_message(**{**_status(i), field: v}) for i, v in enumerate((1, edge))]
    want = [ref.encode(m) for m in msgs]
    assert encode_batch(Codec(1, 1), AMUSSEL_STATUS, cols) == want


@PATHS
@pytest.mark.parametrize(("field", "value"), [("mussel_id", 3.0), ("mussel_id", "3"), ("depth", "1.5")])
def test_values_struct_refuses_raise_naming_the_field(field: str, value: object, few_rows: int,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(hot, "FEW_ROWS", few_rows)
    with pytest.raises(struct.error):
        mavlink.MAVLink_amussel_status_message(**{**_status(0), field: value}).pack(Codec(1, 1).mav)
    cols: dict[str, Any] = _columns(AMUSSEL_STATUS, [_status(0)])
    cols[field] = np.array([value], object if isinstance(value, str) else None)
    with pytest.raises(ValueError, match=field):
        encode_batch(Codec(1, 1), AMUSSEL_STATUS, cols)


def test_missing_or_unknown_fields_raise() -> None:
    cols: dict[str, Any] = _columns(AMUSSEL_STATUS, [_status(0)])
    del cols["state"]
    with pytest.raises(ValueError, match="state"):
        encode_batch(Codec(1, 1), AMUSSEL_STATUS, cols)
    with pytest.raises(ValueError, match="colour"):
        encode_batch(Codec(1, 1), AMUSSEL_STATUS, {**_columns(AMUSSEL_STATUS, [_status(0)]), "colour": [1]})


@PATHS
def test_scalars_broadcast_beside_arrays(few_rows: int, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(hot, "FEW_ROWS", few_rows)
    rows = [_status(i) for i in range(3)]
    cols: dict[str, Any] = _columns(AMUSSEL_STATUS, rows)
    cols["simulated"], cols["depth"] = 1, 2.5
    batch, ref = _pair(1, 1, 0)
    want = [ref.encode(mavlink.MAVLink_amussel_status_message(**r)) for r in rows]
    assert encode_batch(batch, AMUSSEL_STATUS, cols) == want


def test_a_signing_codec_falls_back_to_signed_frames_pymavlink_accepts() -> None:
    batch, ref = _pair(3, 1, 200)
    for c in (batch, ref):
        c.enable_signing(KEY, link_id=2, ticks=lambda: 1000)
    rows = [_status(i) for i in range(80)]
    got = encode_batch(batch, AMUSSEL_STATUS, _columns(AMUSSEL_STATUS, rows))
    assert got == [ref.encode(mavlink.MAVLink_amussel_status_message(**r)) for r in rows]
    assert all(f[2] & mavlink.MAVLINK_IFLAG_SIGNED for f in got)
    rx = Codec(250, 190)
    rx.enable_signing(KEY, link_id=0, ticks=lambda: 1000)
    split = decode_datagram(b"".join(got))  # signed: never arrays, always the verifying path
    assert (len(split.hot), split.others, split.bad) == (0, got, 0)
    assert [m.mussel_id for m in rx.decode(b"".join(split.others))] == [r["mussel_id"] for r in rows]


# ---- datagrams ----------------------------------------------------------------------------------


@settings(max_examples=100, deadline=None)
@given(sizes=st.lists(st.integers(12, 280), max_size=60), limit=st.integers(280, 1500))
def test_datagrams_hold_whole_frames_in_order_and_are_full(sizes: list[int], limit: int) -> None:
    chunks = [bytes([i % 256]) * n for i, n in enumerate(sizes)]
    grams = pack_datagrams(chunks, limit)
    assert b"".join(grams) == b"".join(chunks)
    assert all(0 < len(g) <= limit for g in grams)
    i = 0
    for g in grams:
        used = 0
        while i < len(sizes) and used + sizes[i] <= len(g):
            used, i = used + sizes[i], i + 1
        assert used == len(g)  # the datagram ends where a frame ends
        assert i == len(sizes) or len(g) + sizes[i] > limit  # greedy: the next frame would not have fitted
    assert i == len(sizes)


def test_a_frame_larger_than_a_datagram_raises() -> None:
    with pytest.raises(ValueError, match="280"):
        pack_datagrams([bytes(280)], 279)


# ---- decode -------------------------------------------------------------------------------------


@pytest.mark.parametrize("spec", SPECS, ids=lambda s: s.name)
@settings(max_examples=150, deadline=None)
@given(data=st.data(), seq=st.integers(0, 255))
def test_batch_decode_equals_pymavlink_on_valid_frames(spec: HotSpec, data: st.DataObject, seq: int) -> None:
    rows = data.draw(_rows(spec, 60))
    tx = Codec(data.draw(st.integers(1, 255)), data.draw(st.integers(0, 255)))
    tx.mav.seq = seq
    sent = [tx.encode(spec.cls(**r)) for r in rows]  # pymavlink's own frames, not the batch encoder's
    grams = pack_datagrams(sent, data.draw(st.integers(280, 1400)))
    for gram in grams:
        want = Codec(250, 190).decode(gram)
        split = decode_datagram(gram, spec)
        assert (split.bad, split.others) == (0, [])
        assert _hot_rows(spec, split.hot) == _msg_rows(spec, want)
    split = decode_datagrams(grams, spec)
    assert _hot_rows(spec, split.hot) == _msg_rows(spec, Codec(250, 190).decode(b"".join(sent)))


@pytest.mark.parametrize("length", [0, 1, 5, 20, 29, 30, 31, 40])
def test_short_and_long_payloads_decode_as_pymavlink_does(length: int) -> None:
    """MAVLink 2 pads short payloads with zeros and ignores bytes past the fields it knows (extensions)."""
    payload = bytes(range(1, length + 1))
    body = bytes([length, 0, 0, 9, 4, 2]) + AMUSSEL_STATUS.msg_id.to_bytes(3, "little") + payload
    crc = mavlink.mcrf4xx(body + bytes([AMUSSEL_STATUS.crc_extra]), 0xFFFF)
    frame = b"\xfd" + body + crc.to_bytes(2, "little")
    want = Codec(250, 190).decode(frame)
    split = decode_datagram(frame)
    assert len(want) == 1 and split.bad == 0
    assert _hot_rows(AMUSSEL_STATUS, split.hot) == _msg_rows(AMUSSEL_STATUS, want)


def _mixed_datagram() -> tuple[bytes, list[bytes], list[bytes]]:
    """Status frames with a HEARTBEAT and an AMUSSEL_SENSORS frame between them: (datagram, status, others)."""
    tx = Codec(1, 1)
    status = encode_batch(tx, AMUSSEL_STATUS, _columns(AMUSSEL_STATUS, [_status(i) for i in range(12)]))
    beat = tx.encode(HEARTBEAT)
    sensors = tx.encode(mavlink.MAVLink_amussel_sensors_message(5, 3, 7.5, 12.0, 1013.0, 0.0))
    others = [beat, sensors]
    return b"".join([*status[:4], beat, *status[4:9], sensors, *status[9:]]), status, others


def test_a_datagram_mixing_status_and_heartbeat_frames_splits_into_both() -> None:
    gram, _status_frames, others = _mixed_datagram()
    stats = Codec(2, 2).stats
    split = decode_datagram(gram, stats=stats)
    assert split.others == others
    assert split.hot.fields["mussel_id"].tolist() == list(range(1, 13))
    assert split.hot.seq.tolist() == list(range(12))
    assert (split.bad, stats.received, stats.bad_data) == (0, 12, 0)
    assert [m.get_type() for m in Codec(2, 2).decode(b"".join(split.others))] == ["HEARTBEAT", "AMUSSEL_SENSORS"]


@settings(max_examples=200, deadline=None)
@given(frame=st.integers(0, 11), at=st.integers(0, 100), flip=st.integers(1, 255))
def test_a_flipped_payload_byte_is_counted_and_that_frame_not_returned(frame: int, at: int, flip: int) -> None:
    tx = Codec(1, 1)
    status = encode_batch(tx, AMUSSEL_STATUS, _columns(AMUSSEL_STATUS, [_status(i) for i in range(12)]))
    broken = bytearray(status[frame])
    broken[10 + at % broken[1]] ^= flip
    gram = b"".join([*status[:frame], bytes(broken), *status[frame + 1 :]])
    stats = Codec(2, 2).stats
    split = decode_datagram(gram, stats=stats)
    assert split.hot.fields["mussel_id"].tolist() == [i + 1 for i in range(12) if i != frame]
    assert (split.bad, stats.bad_data, split.others) == (1, 1, [])


@settings(max_examples=400, deadline=None)
@given(at=st.integers(0, 10_000), flip=st.integers(1, 255), cut=st.integers(0, 40))
def test_any_corrupted_byte_or_cut_tail_gives_what_pymavlink_gives(at: int, flip: int, cut: int) -> None:
    gram, _, _ = _mixed_datagram()
    broken = bytearray(gram)
    broken[at % len(gram)] ^= flip
    broken = broken[: len(broken) - cut]
    want = Codec(250, 190).decode(bytes(broken))
    split = decode_datagram(bytes(broken))
    want_status = [m for m in want if m.get_msgId() == AMUSSEL_STATUS.msg_id]
    assert _hot_rows(AMUSSEL_STATUS, split.hot) == _msg_rows(AMUSSEL_STATUS, want_status)
    rest = Codec(250, 190).decode(b"".join(split.others))
    want_rest = [m for m in want if m.get_msgId() != AMUSSEL_STATUS.msg_id]
    assert [m.get_msgbuf() for m in rest] == [m.get_msgbuf() for m in want_rest]


@pytest.mark.parametrize("junk", [b"\x00", b"\x00junk"])
@pytest.mark.parametrize("tail", [1, 5, 11, 12, 39, 41], ids=lambda n: f"{n}-bytes")
def test_garbage_and_a_truncated_tail_are_counted_not_returned(junk: bytes, tail: int) -> None:
    gram, status, others = _mixed_datagram()
    split = decode_datagram(junk + gram + status[0][:tail])  # a whole status frame is 42 bytes
    assert len(split.hot) == 12 and split.others == others
    assert split.bad == 2


@settings(max_examples=100, deadline=None)
@given(limit=st.integers(280, 700), cuts=st.lists(st.integers(0, 30), min_size=1, max_size=6))
def test_several_datagrams_at_once_equal_one_at_a_time(limit: int, cuts: list[int]) -> None:
    """A frame never continues in the next datagram: a cut tail is bad there, not glued to what follows."""
    gram, _, _ = _mixed_datagram()
    grams = pack_datagrams([gram[i : i + 42] for i in range(0, len(gram), 42)], limit)  # not frame-aligned
    grams = [g[: len(g) - cuts[k % len(cuts)]] for k, g in enumerate(grams)]
    one = [decode_datagram(g) for g in grams]
    many = decode_datagrams(grams)
    assert _hot_rows(AMUSSEL_STATUS, many.hot) == [r for s in one for r in _hot_rows(AMUSSEL_STATUS, s.hot)]
    assert (many.others, many.bad) == ([f for s in one for f in s.others], sum(s.bad for s in one))


def test_mavlink1_frames_pass_through_whole() -> None:
    # custom_mode 0x00D2F001 puts AMUSSEL_STATUS's id where a MAVLink 2 header keeps it, seq 0 its flags
    beat = mavlink.MAVLink_heartbeat_message(11, 3, 0, 0x00D2F001, 4, 3)
    v1 = beat.pack(mavlink.MAVLink(None, 9, 1), force_mavlink1=True)
    assert v1[7:10] == AMUSSEL_STATUS.msg_id.to_bytes(3, "little") and v1[2] == 0
    status = encode_batch(Codec(1, 1), AMUSSEL_STATUS, _columns(AMUSSEL_STATUS, [_status(i) for i in range(3)]))
    split = decode_datagram(status[0] + v1 + v1 + b"".join(status[1:]))
    assert (split.hot.fields["mussel_id"].tolist(), split.others, split.bad) == ([1, 2, 3], [v1, v1], 0)
    assert [m.get_type() for m in Codec(2, 2).decode(b"".join(split.others))] == ["HEARTBEAT"] * 2


@pytest.mark.parametrize("msg_id", [54099, 54000 + (1 << 16), 54000 + (1 << 20)])
def test_unknown_message_ids_go_to_the_normal_path(msg_id: int) -> None:
    frame = bytearray(Codec(1, 1).encode(mavlink.MAVLink_amussel_status_message(**_status(0))))
    frame[7:10] = msg_id.to_bytes(3, "little")
    split = decode_datagram(bytes(frame))
    assert (len(split.hot), split.others, split.bad) == (0, [bytes(frame)], 0)
    rx = Codec(2, 2)
    assert rx.decode(split.others[0]) == [] and rx.stats.unknown == 1


def test_a_tlog_of_batch_frames_reads_with_pymavlinks_parser(tmp_path: Path) -> None:
    rows = [_status(i) for i in range(300)]
    batch = encode_batch(Codec(5, 1), AMUSSEL_STATUS, _columns(AMUSSEL_STATUS, rows))
    path = tmp_path / "batch.tlog"
    log = TlogWriter(path)
    for k in range(0, len(batch), 100):
        log.write_many(k * 10_000, batch[k : k + 100])
    log.close()
    mav = mavlink.MAVLink(None)
    got: list[mavlink.MAVLink_message] = []
    for _stamp, frame in frames(path):
        got += mav.parse_buffer(frame) or []
    assert [m.get_type() for m in got] == ["AMUSSEL_STATUS"] * 300
    assert [(m.mussel_id, m.lat, m.get_seq()) for m in got] == [
        (r["mussel_id"], r["lat"], i % 256) for i, r in enumerate(rows)
    ]
