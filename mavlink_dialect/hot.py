"""A batch path for the bulk messages (AMUSSEL_STATUS, AMUSSEL_SENSORS): numpy in, frames out, and back.

pymavlink packs and parses one Python object per message (~5 µs / ~7 µs). Here a whole fleet's
messages are one numpy structured array; per frame there is only the CRC call (the `fastcrc`
mcrf4xx pymavlink uses) and a split, both iterated in C. Frames are byte-identical to
`Codec.encode` (tests/unit/test_hot_path.py holds that), so every MAVLink tool still reads them.

    frames = encode_batch(codec, AMUSSEL_STATUS, {"time_us": t, "mussel_id": ids, ...})
    for datagram in pack_datagrams(frames): transport.send(datagram)
    ...
    split = decode_datagrams(transport.receive(), stats=codec.stats)  # split.hot.fields["lat"] ...
    msgs = codec.decode(b"".join(split.others))  # everything else (signed, other ids) the normal way
"""

from __future__ import annotations

import numbers
import operator
import re
import struct
from bisect import bisect_right
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from itertools import accumulate, repeat

import numpy as np
from numpy.typing import ArrayLike

from mavlink_dialect import subcultron as mavlink
from mavlink_dialect.codec import Codec, CodecStats

if mavlink.mcrf4xx is None:  # pragma: no cover - pymavlink requires fastcrc
    raise ImportError("mavlink_dialect.hot needs fastcrc (pymavlink's CRC)")
_crc = mavlink.mcrf4xx  # pymavlink's own choice (fastcrc, a dependency of pymavlink)

HEADER = mavlink.HEADER_LEN_V2  # magic, len, incompat, compat, seq, sys, comp, msgid24
OVERHEAD = HEADER + 2  # + CRC16
SIGNATURE = mavlink.MAVLINK_SIGNATURE_BLOCK_LEN
V1_OVERHEAD = mavlink.HEADER_LEN_V1 + 2
MAGIC_V1, MAGIC_V2 = mavlink.PROTOCOL_MARKER_V1, mavlink.PROTOCOL_MARKER_V2
_MAGIC = re.compile(rb"[\xfd\xfe]")
DATAGRAM_BYTES = 1400  # below a WiFi/Ethernet MTU once IP and UDP headers are added

# struct format characters -> little-endian numpy types (struct's "<" format has no padding)
_NUMPY = {"B": "u1", "b": "i1", "H": "<u2", "h": "<i2", "I": "<u4", "i": "<i4",
          "Q": "<u8", "q": "<i8", "f": "<f4", "d": "<f8"}  # fmt: skip


@dataclass(frozen=True)
class HotSpec:
    """What batch packing needs of one message class, read from the generated module."""

    cls: type[mavlink.MAVLink_message]
    name: str
    msg_id: int
    crc_extra: int
    fieldnames: tuple[str, ...]  # constructor order, as pymavlink exposes them
    dtype: np.dtype  # wire order, packed, little-endian: one record is one full payload

    @property
    def size(self) -> int:
        return int(self.dtype.itemsize)


def spec_for(cls: type[mavlink.MAVLink_message]) -> HotSpec:
    """The batch spec of a message with scalar fields only (arrays and strings stay on pymavlink)."""
    fmt = cls.unpacker.format  # every generated class has one
    if not fmt.startswith("<") or any(n != 0 for n in cls.array_lengths):
        raise ValueError(f"{cls.msgname}: only little-endian messages of scalar fields are supported")
    codes = re.findall(r"\d*[a-zA-Z?]", fmt[1:])
    if any(c not in _NUMPY for c in codes) or len(codes) != len(cls.ordered_fieldnames):
        raise ValueError(f"{cls.msgname}: format {fmt!r} has fields this batch path does not pack")
    dtype = np.dtype([(f, _NUMPY[c]) for f, c in zip(cls.ordered_fieldnames, codes, strict=True)])
    assert dtype.itemsize == cls.unpacker.size
    return HotSpec(cls, cls.msgname, cls.id, cls.crc_extra, tuple(cls.fieldnames), dtype)


AMUSSEL_STATUS = spec_for(mavlink.MAVLink_amussel_status_message)
AMUSSEL_SENSORS = spec_for(mavlink.MAVLink_amussel_sensors_message)


# ---- encode -------------------------------------------------------------------------------------


_SAME_VALUE = np.lib.NumpyVersion(np.__version__) >= "2.4.0"  # astype(casting="same_value")


_F32_SAFE = 3.0e38  # below float32's largest finite value: a cast cannot overflow


def _real(value: object) -> float:
    if not isinstance(value, numbers.Real):
        raise TypeError(value)
    return float(value)  # OverflowError for an int beyond a double, as struct


def _refused(spec: HotSpec, name: str, why: str) -> ValueError:
    return ValueError(f"{spec.name}.{name} ({spec.dtype.fields[name][0]}, struct.error): {why}")  # type: ignore[index]


def _column(spec: HotSpec, name: str, values: np.ndarray) -> np.ndarray:
    """`values` converted to the field's wire type; ValueError where struct.pack would refuse one."""
    target = spec.dtype.fields[name][0]  # type: ignore[index]
    if values.dtype.kind == "O":  # Python numbers beyond 64 bits, or a mix: taken one by one, as struct does
        try:
            items = [_real(v) if target.kind == "f" else operator.index(v) for v in values.ravel().tolist()]
        except (TypeError, OverflowError):
            raise _refused(spec, name, "not a number, or too large") from None
        values = np.array(items, np.float64 if target.kind == "f" or not items else None).reshape(values.shape)
    kind = values.dtype.kind
    if target.kind == "f":
        if kind not in "fiub":
            raise _refused(spec, name, f"{values.dtype} values are not real numbers")
        if values.dtype == target:
            return values
        wide = values.astype(np.float64, copy=False)  # as struct: to double first (no double rounding of ints)
        if target.itemsize == 8 or (wide.size and float(np.abs(wide).max()) < _F32_SAFE):
            return wide.astype(target)  # nothing to overflow, no NaN: no errstate (3 us of a 6 us column)
        with np.errstate(over="ignore", invalid="ignore"):  # overflow checked below; sNaN quietened as C does
            out = wide.astype(target)
        if target.itemsize == 4 and np.isinf(out).any() and np.any(np.isinf(out) & np.isfinite(wide)):
            raise _refused(spec, name, "finite value too large for a float32")
        return out
    if kind == "O":  # integers no single 64-bit type holds: some are out of any target's range
        raise _refused(spec, name, "value out of range")
    if kind not in "iub":  # struct refuses floats for integer fields, even 3.0
        raise _refused(spec, name, f"{values.dtype} values, required argument is not an integer")
    ints = _cast_ints(values, target)
    if ints is None:
        raise _refused(spec, name, "value out of range")
    return ints


def _cast_ints(values: np.ndarray, target: np.dtype) -> np.ndarray | None:
    """`values` as `target`, or None if one of them does not fit."""
    if _SAME_VALUE:
        try:  # one cast that refuses to change a value: the range check at the price of the cast
            return values.astype(target, casting="same_value")  # numpy >= 2.4 only (see _SAME_VALUE)
        except ValueError:
            return None
    info = np.iinfo(target)
    if values.size and (int(values.min()) < info.min or int(values.max()) > info.max):
        return None
    return values.astype(target)


def pack_records(spec: HotSpec, columns: Mapping[str, ArrayLike]) -> np.ndarray:
    """One record per message: every field of `spec` given as an (n,) array or a scalar for all."""
    if columns.keys() != set(spec.fieldnames):
        missing, unknown = set(spec.fieldnames) - columns.keys(), columns.keys() - set(spec.fieldnames)
        raise ValueError(f"{spec.name}: missing fields {sorted(missing)}, unknown fields {sorted(unknown)}")
    arrays = {f: np.asarray(columns[f]) for f in spec.fieldnames}
    shapes = {a.shape for a in arrays.values()} - {()}  # scalars broadcast
    if len(shapes) != 1 or len(shape := shapes.pop()) != 1:
        raise ValueError(f"{spec.name}: fields must be (n,) arrays of one length (or scalars beside them)")
    rec = np.empty(shape, spec.dtype)
    for name, values in arrays.items():
        rec[name] = _column(spec, name, values)
    return rec


def encode_batch(codec: Codec, spec: HotSpec, columns: Mapping[str, ArrayLike]) -> list[bytes]:
    """n MAVLink 2 frames, byte for byte what `codec.encode` gives one message at a time (same seq run).

    `columns`: every field of `spec` by name, as (n,) arrays or scalars for all. ValueError (naming
    the field) for a value struct.pack would refuse; then no sequence number is used.
    """
    rec = pack_records(spec, columns)  # validate everything before taking sequence numbers
    n = len(rec)
    if n == 0:
        return []
    if codec.mav.signing.sign_outgoing:  # SHA-256 per frame: pymavlink's path, one by one
        cols = [rec[f].tolist() for f in spec.fieldnames]
        return [codec.encode(spec.cls(*row)) for row in zip(*cols, strict=True)]
    size = spec.size
    payload = rec.view(np.uint8).reshape(n, size)
    # MAVLink 2 drops trailing zero bytes of the payload but keeps the first (MAVLink_message._pack)
    keep = payload != 0
    keep[:, 0] = True
    plen = size - keep[:, ::-1].argmax(axis=1)
    head = np.empty((n, HEADER), np.uint8)
    ids = bytes([MAGIC_V2, 0, 0, 0, 0, codec.system_id, codec.component_id]) + spec.msg_id.to_bytes(3, "little")
    head[:] = np.frombuffer(ids, np.uint8)
    head[:, 1] = plen
    head[:, 4] = (codec.next_seq(n) + np.arange(n)) % 256
    lengths = [int(plen[0])] if plen.min() == plen.max() else np.unique(plen).tolist()
    frames: list[bytes] = []
    order = []
    for length in lengths:  # one length per group of equal-width frames; a fleet's usually all end alike
        rows = np.flatnonzero(plen == length) if len(lengths) > 1 else np.arange(n)
        buf = np.empty((len(rows), OVERHEAD + length), np.uint8)
        buf[:, :HEADER] = head[rows]
        buf[:, HEADER:-2] = payload[rows, :length]
        buf[:, -2] = spec.crc_extra  # the CRC covers len .. payload plus crc_extra: one call per frame
        crcs = np.fromiter(map(_crc, _rows(buf[:, 1:-1])), np.uint16, len(rows))
        buf[:, -2] = crcs & 0xFF
        buf[:, -1] = crcs >> 8
        frames += _rows(buf)
        order.append(rows)
    if len(lengths) == 1:
        return frames
    return list(map(frames.__getitem__, np.argsort(np.concatenate(order)).tolist()))  # back in input order


def _rows(table: np.ndarray) -> list[bytes]:
    """Each row of a 2-D uint8 array as bytes, split in C (struct) rather than sliced in Python."""
    return list(map(operator.itemgetter(0), struct.iter_unpack(f"{table.shape[1]}s", table.tobytes())))


def _slices(data: bytes, starts: np.ndarray, ends: np.ndarray) -> Iterator[bytes]:
    """data[s:e] for each pair, iterated in C: no Python bytecode per frame."""
    return map(data.__getitem__, map(slice, starts.tolist(), ends.tolist()))


def pack_datagrams(frames: Iterable[bytes], max_bytes: int = DATAGRAM_BYTES) -> list[bytes]:
    """Whole frames joined into datagrams of at most `max_bytes`, in order; a frame is never split."""
    frames = list(frames)
    sizes = list(map(len, frames))
    if sizes and max(sizes) > max_bytes:
        raise ValueError(f"a {max(sizes)}-byte frame does not fit a {max_bytes}-byte datagram")
    ends = list(accumulate(sizes))  # greedy fill, found by bisection: Python work per datagram, not per frame
    datagrams: list[bytes] = []
    start = 0
    while start < len(frames):
        stop = bisect_right(ends, (ends[start - 1] if start else 0) + max_bytes, lo=start)
        datagrams.append(b"".join(frames[start:stop]))
        start = stop
    return datagrams


# ---- decode -------------------------------------------------------------------------------------


@dataclass
class HotFrames:
    """The valid unsigned frames of one message type, one array element per frame, in arrival order."""

    fields: dict[str, np.ndarray]  # per field name, wire types (float32 stays float32)
    src_system: np.ndarray  # uint8
    src_component: np.ndarray  # uint8
    seq: np.ndarray  # uint8
    raw: list[bytes] | None = None  # the frames themselves, when asked for (a log records them)

    def __len__(self) -> int:
        return len(self.seq)


@dataclass
class Split:
    hot: HotFrames
    others: list[bytes]  # every other frame, untouched, for `Codec.decode` (which checks CRC, signature)
    bad: int  # CRC failures, garbage runs and a truncated tail: dropped here


def decode_datagram(data: bytes, spec: HotSpec = AMUSSEL_STATUS, stats: CodecStats | None = None) -> Split:
    """Split one datagram of whole MAVLink frames; `spec`'s valid unsigned frames come back as arrays.

    Frames are delimited as pymavlink's robust parser does: the length byte gives the size, a bad
    CRC drops that frame, bytes that start no frame are skipped to the next magic (one bad each);
    a frame cut short by the datagram's end is bad too (datagrams do not continue each other).
    With `stats`, `bad_data` and `received` (hot frames only) are counted there too.
    """
    return decode_datagrams([data], spec, stats)


def decode_datagrams(
    datagrams: Iterable[bytes], spec: HotSpec = AMUSSEL_STATUS, stats: CodecStats | None = None,
    keep_raw: bool = False,
) -> Split:
    """`decode_datagram` over several datagrams at once (one receive's worth): one set of arrays.
    `keep_raw` also returns the valid hot frames' bytes (`HotFrames.raw`), for a .tlog."""
    grams = [bytes(g) for g in datagrams]
    data = grams[0] if len(grams) == 1 else b"".join(grams)
    starts: list[int] = []
    ends: list[int] = []
    others: list[bytes] = []
    bad, base = 0, 0
    msg_id = spec.msg_id.to_bytes(3, "little")
    for gram in grams:  # frames never cross a datagram's end
        bad += _walk(data, base, base + len(gram), msg_id, starts, ends, others)
        base += len(gram)
    check = _check_few if len(starts) < FEW_FRAMES else _check_many
    frames, failed = check(spec, data, starts, ends, keep_raw)
    bad += failed
    if stats is not None:
        stats.bad_data += bad
        stats.received += len(frames)
    return Split(frames, others, bad)


# Below this many hot frames a Python loop per frame beats numpy's fixed cost per call (a 12-aMussel
# pool's status, the heartbeats and commands that come without any): measured 2x at n = 12, even at n = 64.
FEW_FRAMES = 64


def _check_few(spec: HotSpec, data: bytes, starts: list[int], ends: list[int], keep_raw: bool) -> tuple[HotFrames, int]:
    """`_check_many` one frame at a time: the same CRC calls, payloads padded or cut alike."""
    size, extra, zeros = spec.size, bytes([spec.crc_extra]), bytes(spec.size)
    payloads: list[bytes] = []
    heads: list[bytes] = []  # seq, sysid, compid
    raw: list[bytes] = []
    for start, end in zip(starts, ends, strict=True):
        crc_end = end - 2
        if _crc(extra, _crc(data[start + 1:crc_end])) != data[crc_end] | data[crc_end + 1] << 8:
            continue
        payload = data[start + HEADER:crc_end]
        payloads.append(payload + zeros[len(payload):] if len(payload) < size else payload[:size])
        heads.append(data[start + 4:start + 7])
        if keep_raw:
            raw.append(data[start:end])
    rec = np.frombuffer(bytearray(b"".join(payloads)), spec.dtype)  # our own copy: writeable
    head = np.frombuffer(b"".join(heads), np.uint8).reshape(len(heads), 3)
    frames = HotFrames({f: rec[f] for f in spec.fieldnames}, head[:, 1].copy(), head[:, 2].copy(), head[:, 0].copy(),
                       raw if keep_raw else None)
    return frames, len(starts) - len(payloads)


def _check_many(
    spec: HotSpec, data: bytes, starts: list[int], ends: list[int], keep_raw: bool
) -> tuple[HotFrames, int]:
    """The hot frames' CRCs checked and their payloads gathered into arrays; and how many failed."""
    raw = np.frombuffer(data + bytes(spec.size + HEADER), np.uint8)  # spare zeros: fixed-width reads stay in
    mine, crc_end = np.array(starts, np.intp), np.array(ends, np.intp) - 2
    extra = repeat(bytes([spec.crc_extra]))
    crcs = np.fromiter(map(_crc, extra, map(_crc, _slices(data, mine + 1, crc_end))), np.int64, len(mine))
    ok = crcs == (raw[crc_end] | raw[crc_end + 1].astype(np.int64) << 8)
    frames = _gather(spec, raw, mine[ok], crc_end[ok] - mine[ok] - HEADER)
    if keep_raw:
        frames.raw = list(_slices(data, mine[ok], crc_end[ok] + 2))
    return frames, int(np.count_nonzero(~ok))


class SharedDecode:
    """`decode_datagrams` for parties that receive the very same datagrams: in a lockstep swarm the
    router hands every aPad the same bytes objects, and each aPad decoding the fleet's 120 statuses
    again was a fifth of a bay120 run. The last answer is kept with the datagrams it was for and
    given again when a call brings those same objects (identity, not equality: a kept object's id
    cannot be reused, and bytes do not change). Each caller's `stats` is still counted. The arrays
    of a shared answer are read-only: one party must not change another's view.
    """

    def __init__(self) -> None:
        self._last: tuple[list[bytes], HotSpec, bool, Split] | None = None

    def decode(
        self, datagrams: list[bytes], spec: HotSpec = AMUSSEL_STATUS, stats: CodecStats | None = None,
        keep_raw: bool = False,
    ) -> Split:
        last = self._last  # read once: one tuple, so a thread never sees half an update
        if (last is not None and last[1] is spec and (last[2] or not keep_raw) and len(last[0]) == len(datagrams)
                and all(map(operator.is_, last[0], datagrams))):
            split = last[3]
        else:
            split = decode_datagrams(datagrams, spec, keep_raw=keep_raw)
            for column in (*split.hot.fields.values(), split.hot.src_system, split.hot.src_component, split.hot.seq):
                column.flags.writeable = False
            self._last = (list(datagrams), spec, keep_raw, split)
        if stats is not None:
            stats.bad_data += split.bad
            stats.received += len(split.hot)
        return split


def _walk(
    data: bytes, i: int, n: int, msg_id: bytes, starts: list[int], ends: list[int], others: list[bytes]
) -> int:
    """Frames in data[i:n]: the unsigned MAVLink 2 frames of `msg_id` (3 bytes, little-endian) to
    `starts`/`ends`, every other frame (signed, other ids, MAVLink 1: the codec's job) to `others`;
    returns how many bad runs were skipped."""
    bad = 0
    while i < n:
        magic = data[i]
        if magic == MAGIC_V2 and i + 2 < n:
            end = i + OVERHEAD + data[i + 1] + (SIGNATURE if data[i + 2] & mavlink.MAVLINK_IFLAG_SIGNED else 0)
        elif magic == MAGIC_V1 and i + 1 < n:
            end = i + V1_OVERHEAD + data[i + 1]
        elif magic in (MAGIC_V1, MAGIC_V2):
            end = n + 1  # too short to read its length
        else:
            bad += 1  # bytes that start no frame: one bad run, up to the next magic
            found = _MAGIC.search(data, i + 1, n)
            i = found.start() if found else n
            continue
        if end > n:
            return bad + 1  # truncated tail
        if magic == MAGIC_V2 and data[i + 2] == 0 and data[i + 7:i + 10] == msg_id:  # unsigned, known flags
            starts.append(i)
            ends.append(end)
        else:
            others.append(data[i:end])
        i = end
    return bad


def _gather(spec: HotSpec, raw: np.ndarray, offsets: np.ndarray, lengths: np.ndarray) -> HotFrames:
    """Payloads zero-padded back to full length (pymavlink's rule), longer ones cut: one record each."""
    cols = np.arange(spec.size)
    payload = raw[offsets[:, None] + (HEADER + cols)]  # `raw` has spare bytes at its end
    if (lengths < spec.size).any():  # truncated ones: bytes past the payload (CRC, next frame) become zeros
        payload[cols >= lengths[:, None]] = 0
    rec = payload.view(spec.dtype).reshape(len(offsets))
    fields = {f: rec[f] for f in spec.fieldnames}  # views of our own copy: free, and safe to modify
    return HotFrames(fields, raw[offsets + 5], raw[offsets + 6], raw[offsets + 4])
