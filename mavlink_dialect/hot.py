"""A batch path for the bulk messages (AMUSSEL_STATUS, AMUSSEL_SENSORS): numpy in, frames out, and back.

pymavlink packs and parses one Python object per message (~5 µs / ~7 µs). Here a whole fleet's
messages are one numpy structured array; per frame there is only the CRC call (the `fastcrc`
mcrf4xx pymavlink uses) and a split, both iterated in C. Frames are byte-identical to
`Codec.encode` (tests/unit/test_hot_path.py holds that), so every MAVLink tool still reads them.

    frames = encode_batch(codec, AMUSSEL_STATUS, {"time_us": t, "mussel_id": ids, ...})
    for datagram in pack_datagrams(frames): transport.send(datagram)

The specs and the encoding are here; the way back (datagrams to columns) is `hot_decode`.
"""

from __future__ import annotations

import numbers
import operator
import re
import struct
from bisect import bisect_right
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from itertools import accumulate, repeat, starmap

import numpy as np
from numpy.typing import ArrayLike

from mavlink_dialect import subcultron as mavlink
from mavlink_dialect.codec import Codec, crc16, frame

crc = crc16  # pymavlink's own choice (fastcrc, a dependency of pymavlink)

HEADER = mavlink.HEADER_LEN_V2  # magic, len, incompat, compat, seq, sys, comp, msgid24
OVERHEAD = HEADER + 2  # + CRC16
SIGNATURE = mavlink.MAVLINK_SIGNATURE_BLOCK_LEN
V1_OVERHEAD = mavlink.HEADER_LEN_V1 + 2
MAGIC_V1, MAGIC_V2 = mavlink.PROTOCOL_MARKER_V1, mavlink.PROTOCOL_MARKER_V2
MAGIC = re.compile(rb"[\xfd\xfe]")
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


# Below this many messages, struct per message beats numpy's fixed cost per call (a 12-aMussel pool's
# statuses: 3x); the numpy path wins from about this many on (bay120's 120, stress240's 240).
FEW_ROWS = 64


@dataclass(frozen=True)
class Encoded:
    """A batch as frames, and the records they were packed from (`spec.dtype`: wire types, full
    payloads), which is exactly what a receiver decodes from those frames."""

    spec: HotSpec
    frames: list[bytes]
    records: np.ndarray
    system_id: int
    component_id: int
    first_seq: int


@dataclass(frozen=True)
class Packed:
    """The last batch this process encoded and then cut into datagrams (`pack_datagrams`).

    A party of the same process that receives those very datagram objects (an in-memory transport
    hands on the objects it was given) can take `encoded.records` instead of parsing the bytes back
    (`hot_decode.SharedDecode`): the same values, without the work, as the GCS router takes the
    fleet's columns. Identity, not equality: a kept object's id cannot be reused.
    """

    datagrams: tuple[bytes, ...]
    encoded: Encoded


_last_encoded: Encoded | None = None
last_packed: Packed | None = None  # read once by a receiver: one assignment, so a thread never sees half


def encode_batch(codec: Codec, spec: HotSpec, columns: Mapping[str, ArrayLike]) -> list[bytes]:
    """n MAVLink 2 frames, byte for byte what `codec.encode` gives one message at a time (same seq run).

    `columns`: every field of `spec` by name, as (n,) arrays or scalars for all. ValueError (naming
    the field) for a value struct.pack would refuse; then no sequence number is used.
    """
    global _last_encoded
    if codec.mav.signing.sign_outgoing:  # SHA-256 per frame: pymavlink's path, one by one
        rec = pack_records(spec, columns)
        cols = [rec[f].tolist() for f in spec.fieldnames]
        return [codec.encode(spec.cls(*row)) for row in zip(*cols, strict=True)]
    payloads = _struct_payloads(spec, columns)
    if payloads is not None:
        rec = np.frombuffer(b"".join(payloads), spec.dtype)
        first = codec.next_seq(len(payloads))
        frames = _frames_few(spec, payloads, first, codec.system_id, codec.component_id)
    else:
        rec = pack_records(spec, columns)  # validate everything before taking sequence numbers
        first = codec.next_seq(len(rec))
        frames = _frames_many(spec, rec, first, codec.system_id, codec.component_id)
    _last_encoded = Encoded(spec, frames, rec, codec.system_id, codec.component_id, first)
    return frames


def _struct_payloads(spec: HotSpec, columns: Mapping[str, ArrayLike]) -> list[bytes] | None:
    """Full payloads packed by struct, one per message, when the batch is small and plain (1-D arrays of
    integers or doubles, Python scalars); None otherwise, or if struct refuses a value: the numpy path
    then decides (it refuses exactly what struct refuses, naming the field)."""
    if columns.keys() != set(spec.fieldnames):
        return None  # the numpy path says which field is missing or unknown
    n = -1
    cols: list[Iterable[object]] = []
    for name in spec.dtype.names or ():  # wire order, as the struct packs
        value = columns[name]
        if isinstance(value, np.ndarray):
            if value.ndim != 1 or (value.dtype.kind not in "iub" and value.dtype != np.float64):
                return None  # float32 keeps its bits only on the numpy path; object arrays go there too
            if n not in (-1, len(value)) or len(value) >= FEW_ROWS:
                return None
            n = len(value)
            cols.append(value.tolist())
        elif type(value) in (int, float):
            cols.append(repeat(value))
        else:
            return None
    if n <= 0:
        return None  # scalars only, or an empty batch
    try:
        return list(starmap(spec.cls.unpacker.pack, zip(*cols, strict=False)))  # scalars repeat for ever
    except (struct.error, OverflowError, TypeError, ValueError):
        return None


def _frames_few(spec: HotSpec, payloads: list[bytes], first: int, system_id: int, component_id: int) -> list[bytes]:
    """One frame per payload, as `MAVLink_message._pack` makes it: trailing zeros cut (one byte kept)."""
    return [frame(spec.msg_id, spec.crc_extra, payload.rstrip(b"\0") or payload[:1], (first + k) & 0xFF,
                  system_id, component_id) for k, payload in enumerate(payloads)]


def _frames_many(spec: HotSpec, rec: np.ndarray, first: int, system_id: int, component_id: int) -> list[bytes]:
    """`_frames_few` for many messages at once: numpy per column, the CRC call per frame iterated in C."""
    n = len(rec)
    if n == 0:
        return []
    size = spec.size
    payload = rec.view(np.uint8).reshape(n, size)
    # MAVLink 2 drops trailing zero bytes of the payload but keeps the first (MAVLink_message._pack)
    keep = payload != 0
    keep[:, 0] = True
    plen = size - keep[:, ::-1].argmax(axis=1)
    head = np.empty((n, HEADER), np.uint8)
    ids = bytes([MAGIC_V2, 0, 0, 0, 0, system_id, component_id]) + spec.msg_id.to_bytes(3, "little")
    head[:] = np.frombuffer(ids, np.uint8)
    head[:, 1] = plen
    head[:, 4] = (first + np.arange(n)) % 256
    lengths = [int(plen[0])] if plen.min() == plen.max() else np.unique(plen).tolist()
    frames: list[bytes] = []
    order = []
    for length in lengths:  # one length per group of equal-width frames; a fleet's usually all end alike
        rows = np.flatnonzero(plen == length) if len(lengths) > 1 else np.arange(n)
        buf = np.empty((len(rows), OVERHEAD + length), np.uint8)
        buf[:, :HEADER] = head[rows]
        buf[:, HEADER:-2] = payload[rows, :length]
        buf[:, -2] = spec.crc_extra  # the CRC covers len .. payload plus crc_extra: one call per frame
        crcs = np.fromiter(map(crc, _rows(buf[:, 1:-1])), np.uint16, len(rows))
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


def slices(data: bytes, starts: np.ndarray, ends: np.ndarray) -> Iterator[bytes]:
    """data[s:e] for each pair, iterated in C: no Python bytecode per frame."""
    return map(data.__getitem__, map(slice, starts.tolist(), ends.tolist()))


def pack_datagrams(frames: Iterable[bytes], max_bytes: int = DATAGRAM_BYTES) -> list[bytes]:
    """Whole frames joined into datagrams of at most `max_bytes`, in order; a frame is never split.
    The datagrams of the batch `encode_batch` made last are remembered with its records (`Packed`)."""
    global last_packed
    encoded = _last_encoded
    given = frames
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
    if encoded is not None and given is encoded.frames and datagrams:
        last_packed = Packed(tuple(datagrams), encoded)
    return datagrams
