"""A batch path for the bulk messages (AMUSSEL_STATUS, AMUSSEL_SENSORS): numpy in, frames out, and back.

pymavlink packs and parses one Python object per message (~5 µs / ~20 µs). Here a whole fleet's
messages are packed as one numpy structured array; the only per-frame Python work is the CRC call
(the same `fastcrc` mcrf4xx pymavlink uses) and a slice. Frames are byte-identical to
`Codec.encode` (tests/unit/test_hot_path.py holds that), so every MAVLink tool still reads them.

    frames = encode_batch(codec, AMUSSEL_STATUS, {"time_us": t, "mussel_id": ids, ...})
    for datagram in pack_datagrams(frames): transport.send(datagram)
    ...
    split = decode_datagram(datagram, stats=codec.stats)  # split.hot.fields["lat"] ...
    msgs = codec.decode(b"".join(split.others))           # everything else, the normal way
"""

from __future__ import annotations

import numbers
import operator
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from mavlink_dialect import subcultron as mavlink
from mavlink_dialect.codec import Codec, CodecStats

_crc = mavlink.mcrf4xx  # pymavlink's own choice (fastcrc, a dependency of pymavlink)
if _crc is None:  # pragma: no cover - pymavlink requires fastcrc
    raise ImportError("mavlink_dialect.hot needs fastcrc (pymavlink's CRC)")

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
    fieldnames: tuple[str, ...]  # constructor order, as pymavlink exposes them
    dtype: np.dtype  # wire order, packed, little-endian: one record is one full payload

    @property
    def name(self) -> str:
        return str(self.cls.msgname)

    @property
    def msg_id(self) -> int:
        return int(self.cls.id)

    @property
    def crc_extra(self) -> int:
        return int(self.cls.crc_extra)

    @property
    def size(self) -> int:
        return int(self.dtype.itemsize)


def spec_for(cls: type[mavlink.MAVLink_message]) -> HotSpec:
    """The batch spec of a message with scalar fields only (arrays and strings stay on pymavlink)."""
    fmt = cls.unpacker.format  # type: ignore[attr-defined]  # every generated class has one
    if not fmt.startswith("<") or any(n != 0 for n in cls.array_lengths):  # type: ignore[attr-defined]
        raise ValueError(f"{cls.msgname}: only little-endian messages of scalar fields are supported")
    codes = re.findall(r"\d*[a-zA-Z?]", fmt[1:])
    if any(c not in _NUMPY for c in codes) or len(codes) != len(cls.ordered_fieldnames):
        raise ValueError(f"{cls.msgname}: format {fmt!r} has fields this batch path does not pack")
    dtype = np.dtype([(f, _NUMPY[c]) for f, c in zip(cls.ordered_fieldnames, codes, strict=True)])
    assert dtype.itemsize == cls.unpacker.size  # type: ignore[attr-defined]
    return HotSpec(cls, tuple(cls.fieldnames), dtype)


AMUSSEL_STATUS = spec_for(mavlink.MAVLink_amussel_status_message)
AMUSSEL_SENSORS = spec_for(mavlink.MAVLink_amussel_sensors_message)


# ---- encode -------------------------------------------------------------------------------------


_NOT_INT = "required argument is not an integer"


def _real(value: object) -> float:
    if not isinstance(value, numbers.Real):
        raise TypeError(value)
    return float(value)


def _column(spec: HotSpec, name: str, values: np.ndarray) -> np.ndarray:
    """`values` converted to the field's wire type; ValueError where struct.pack would refuse them."""
    target = spec.dtype[name]
    where = f"{spec.name}.{name}"
    if target.kind == "f":
        if values.dtype.kind == "O":  # Python ints beyond int64, or a mix: float() each, as struct does
            try:
                values = np.array([_real(v) for v in values.tolist()], np.float64)
            except (TypeError, OverflowError):
                raise ValueError(f"{where}: values that are not real numbers or too large (struct.error)") from None
        elif values.dtype.kind not in "fiub":
            raise ValueError(f"{where}: {values.dtype} values, need real numbers (struct.error)")
        wide = values.astype(np.float64)  # as struct does: to double first (no double rounding from ints)
        with np.errstate(over="ignore", invalid="ignore"):  # overflow checked below; sNaN quietened as C does
            out = wide.astype(target)
        if target.itemsize == 4 and np.any(np.isinf(out) & np.isfinite(wide)):
            raise ValueError(f"{where}: finite value too large for a float32 (struct: 'float too large')")
        return out
    info = np.iinfo(target)
    if values.dtype.kind == "O":  # Python ints beyond int64/uint64, or a mix: check them one by one
        try:
            ints = [operator.index(v) for v in values.tolist()]
        except TypeError:
            raise ValueError(f"{where}: non-integer values (struct.error: {_NOT_INT})") from None
        lo, hi = (min(ints), max(ints)) if ints else (0, 0)
    elif values.dtype.kind in "iub":
        lo, hi = (int(values.min()), int(values.max())) if values.size else (0, 0)
    else:
        raise ValueError(f"{where}: {values.dtype} values (struct.error: {_NOT_INT})")
    if lo < info.min or hi > info.max:
        raise ValueError(f"{where}: value out of range {info.min}..{info.max} for {target} (struct.error)")
    return values.astype(target)


def pack_records(spec: HotSpec, columns: Mapping[str, ArrayLike]) -> np.ndarray:
    """One record per message: every field of `spec` given as an (n,) array or a scalar for all."""
    missing, unknown = set(spec.fieldnames) - set(columns), set(columns) - set(spec.fieldnames)
    if missing or unknown:
        raise ValueError(f"{spec.name}: missing fields {sorted(missing)}, unknown fields {sorted(unknown)}")
    arrays = np.broadcast_arrays(*(np.asarray(columns[f]) for f in spec.fieldnames))
    if arrays[0].ndim != 1:
        raise ValueError(f"{spec.name}: fields must be (n,) arrays (or scalars beside them)")
    rec = np.empty(arrays[0].shape[0], spec.dtype)
    for name, values in zip(spec.fieldnames, arrays, strict=True):
        rec[name] = _column(spec, name, values)
    return rec


def encode_batch(codec: Codec, spec: HotSpec, columns: Mapping[str, ArrayLike]) -> list[bytes]:
    """n MAVLink 2 frames, byte for byte what `codec.encode` gives one message at a time (same seq run)."""
    rec = pack_records(spec, columns)  # validate everything before taking sequence numbers
    n = len(rec)
    if n == 0:
        return []
    if codec.mav.signing.sign_outgoing:  # SHA-256 per frame: pymavlink's path, one by one
        cols = [rec[f].tolist() for f in spec.fieldnames]
        return [codec.encode(spec.cls(*row)) for row in zip(*cols, strict=True)]
    size, width = spec.size, OVERHEAD + spec.size
    payload = rec.view(np.uint8).reshape(n, size)
    nonzero = payload != 0
    # MAVLink 2 drops trailing zero bytes of the payload, keeping at least one (MAVLink_message._pack)
    plen = np.where(nonzero.any(axis=1), size - nonzero[:, ::-1].argmax(axis=1), 1)
    first = codec.next_seq(n)
    buf = np.zeros((n, width), np.uint8)
    buf[:, 0] = MAGIC_V2
    buf[:, 1] = plen
    buf[:, 4] = (first + np.arange(n)) % 256
    buf[:, 5], buf[:, 6] = codec.system_id, codec.component_id
    buf[:, 7:10] = np.frombuffer(spec.msg_id.to_bytes(3, "little"), np.uint8)
    buf[:, HEADER : HEADER + size] = payload
    rows, crc_at = np.arange(n), HEADER + plen
    buf[rows, crc_at] = spec.crc_extra  # the CRC covers len..payload plus crc_extra: one call per frame
    starts = rows * width
    ends = starts + crc_at + 2
    spans = list(zip(starts.tolist(), ends.tolist(), strict=True))
    flat = memoryview(buf.reshape(-1))
    crcs = np.array([_crc(flat[s + 1 : e - 1], 0xFFFF) for s, e in spans])
    buf[rows, crc_at] = crcs & 0xFF
    buf[rows, crc_at + 1] = crcs >> 8
    raw = buf.tobytes()
    return [raw[s:e] for s, e in spans]


def pack_datagrams(frames: Iterable[bytes], max_bytes: int = DATAGRAM_BYTES) -> list[bytes]:
    """Whole frames joined into datagrams of at most `max_bytes`, in order; a frame is never split."""
    datagrams: list[bytes] = []
    chunk: list[bytes] = []
    used = 0
    for frame in frames:
        if len(frame) > max_bytes:
            raise ValueError(f"a {len(frame)}-byte frame does not fit a {max_bytes}-byte datagram")
        if used + len(frame) > max_bytes:
            datagrams.append(b"".join(chunk))
            chunk, used = [], 0
        chunk.append(frame)
        used += len(frame)
    if chunk:
        datagrams.append(b"".join(chunk))
    return datagrams


# ---- decode -------------------------------------------------------------------------------------


@dataclass
class HotFrames:
    """The valid unsigned frames of one message type, one array element per frame, in arrival order."""

    fields: dict[str, np.ndarray]  # per field name, wire types (float32 stays float32)
    src_system: np.ndarray  # uint8
    src_component: np.ndarray  # uint8
    seq: np.ndarray  # uint8

    def __len__(self) -> int:
        return len(self.seq)


@dataclass
class Split:
    hot: HotFrames
    others: list[bytes]  # every other frame, untouched, for `Codec.decode` (which checks CRC, signature)
    bad: int  # CRC failures, garbage runs and a truncated tail: dropped here


def decode_datagram(data: bytes, spec: HotSpec = AMUSSEL_STATUS, stats: CodecStats | None = None) -> Split:
    """Split one datagram of whole MAVLink frames; `spec`'s unsigned frames come back as arrays.

    Frames are delimited as pymavlink's robust parser does: the length byte gives the size, a bad
    CRC drops that frame, bytes that start no frame are skipped to the next magic (one bad each).
    With `stats`, `bad_data` and `received` (hot frames only) are counted there too.
    """
    n, i, bad = len(data), 0, 0
    view = memoryview(data)
    msgid = spec.msg_id.to_bytes(3, "little")
    extra = bytes([spec.crc_extra])
    offsets: list[int] = []
    lengths: list[int] = []
    others: list[bytes] = []
    while i < n:
        magic = data[i]
        if magic != MAGIC_V2 and magic != MAGIC_V1:
            bad += 1  # bytes that start no frame: one bad run, up to the next magic
            found = _MAGIC.search(data, i + 1)
            i = found.start() if found else n
            continue
        v2 = magic == MAGIC_V2
        if i + (OVERHEAD if v2 else V1_OVERHEAD) > n:
            bad += 1  # truncated tail: a datagram never continues in the next one
            break
        length = data[i + 1]
        if not v2:
            size = V1_OVERHEAD + length
        else:
            size = OVERHEAD + length + (SIGNATURE if data[i + 2] & mavlink.MAVLINK_IFLAG_SIGNED else 0)
        if i + size > n:
            bad += 1
            break
        if v2 and data[i + 2] == 0 and data[i + 7 : i + 10] == msgid:
            end = i + HEADER + length
            if _crc(extra, _crc(view[i + 1 : end], 0xFFFF)) == data[end] | data[end + 1] << 8:
                offsets.append(i)
                lengths.append(length)
            else:
                bad += 1  # like pymavlink: the whole frame goes, parsing resumes after it
        else:  # signed (the codec checks signatures), other ids, MAVLink 1, unknown flags: normal path
            others.append(bytes(data[i : i + size]))
        i += size
    hot = _gather(spec, np.frombuffer(data, np.uint8), np.array(offsets, np.intp), np.array(lengths, np.intp))
    if stats is not None:
        stats.bad_data += bad
        stats.received += len(hot)
    return Split(hot, others, bad)


def _gather(spec: HotSpec, raw: np.ndarray, offsets: np.ndarray, lengths: np.ndarray) -> HotFrames:
    """Payloads zero-padded back to full length (pymavlink's rule), longer ones cut: one record each."""
    cols = np.arange(spec.size)
    at = np.minimum(offsets[:, None] + HEADER + cols, len(raw) - 1)  # past the payload: masked below
    payload = np.where(cols < lengths[:, None], raw[at], 0).astype(np.uint8)
    rec = payload.view(spec.dtype).reshape(len(offsets))
    fields = {f: rec[f].copy() for f in spec.fieldnames}
    return HotFrames(fields, raw[offsets + 5], raw[offsets + 6], raw[offsets + 4])
