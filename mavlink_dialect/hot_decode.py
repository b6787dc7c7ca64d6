"""The way back for the bulk messages: datagrams in, AMUSSEL_STATUS / AMUSSEL_SENSORS columns out.

The counterpart of `hot` (the specs and the encoding): a datagram's frames are walked once, the
hot ones checked (CRC, length) and gathered into a structured array, the rest handed on as bytes
for the ordinary `Codec` (signed frames, other ids).

    split = decode_datagrams(transport.receive(), stats=codec.stats)  # split.hot.fields["lat"] ...
    msgs = codec.decode(b"".join(split.others))  # everything else (signed, other ids) the normal way
"""

from __future__ import annotations

import operator
from collections.abc import Iterable
from dataclasses import dataclass
from itertools import repeat

import numpy as np

from mavlink_dialect import hot
from mavlink_dialect import subcultron as mavlink
from mavlink_dialect.codec import CodecStats
from mavlink_dialect.hot import (
    AMUSSEL_STATUS,
    HEADER,
    MAGIC,
    MAGIC_V1,
    MAGIC_V2,
    OVERHEAD,
    SIGNATURE,
    V1_OVERHEAD,
    HotSpec,
    crc,
    slices,
)


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
    msg_id = spec.msg_id.to_bytes(3, "little")
    if grams and all(_one_other_frame(g, msg_id) for g in grams):
        return Split(_empty(spec, [] if keep_raw else None), grams, 0)  # a heartbeat, a command: nothing to walk
    data = grams[0] if len(grams) == 1 else b"".join(grams)
    starts: list[int] = []
    ends: list[int] = []
    others: list[bytes] = []
    bad, base = 0, 0
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
        if crc(extra, crc(data[start + 1:crc_end])) != data[crc_end] | data[crc_end + 1] << 8:
            continue
        payload = data[start + HEADER:crc_end]
        payloads.append(payload + zeros[len(payload):] if len(payload) < size else payload[:size])
        heads.append(data[start + 4:start + 7])
        if keep_raw:
            raw.append(data[start:end])
    if not payloads:  # the common case (heartbeats, commands): no numpy at all
        return _empty(spec, [] if keep_raw else None), len(starts)
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
    crcs = np.fromiter(map(crc, extra, map(crc, slices(data, mine + 1, crc_end))), np.int64, len(mine))
    ok = crcs == (raw[crc_end] | raw[crc_end + 1].astype(np.int64) << 8)
    frames = _gather(spec, raw, mine[ok], crc_end[ok] - mine[ok] - HEADER)
    if keep_raw:
        frames.raw = list(slices(data, mine[ok], crc_end[ok] + 2))
    return frames, int(np.count_nonzero(~ok))


class SharedDecode:
    """`decode_datagrams` for parties that receive the very same datagrams: in a lockstep swarm the
    router hands every aPad the same bytes objects, and each aPad decoding the fleet's 120 statuses
    again was a fifth of a bay120 run. The last answer is kept with the datagrams it was for and
    given again when a call brings those same objects (identity, not equality: a kept object's id
    cannot be reused, and bytes do not change). Datagrams this process packed itself
    (`hot.last_packed`: an in-memory transport hands on the sender's objects) are not parsed at
    all: their records are the values the bytes hold. Each caller's `stats` is still counted. The
    arrays of a shared answer are read-only: one party must not change another's view.
    """

    def __init__(self) -> None:
        self._last: tuple[list[bytes], HotSpec, bool, Split] | None = None
        self._packed: tuple[hot.Packed, HotFrames] | None = None

    def decode(
        self, datagrams: list[bytes], spec: HotSpec = AMUSSEL_STATUS, stats: CodecStats | None = None,
        keep_raw: bool = False,
    ) -> Split:
        last = self._last  # read once: one tuple, so a thread never sees half an update
        if (last is not None and last[1] is spec and (last[2] or not keep_raw) and len(last[0]) == len(datagrams)
                and all(map(operator.is_, last[0], datagrams))):
            split = last[3]
        else:
            split = self._sent_here(datagrams, spec) or self._decoded(datagrams, spec, keep_raw)
            self._last = (list(datagrams), spec, split.hot.raw is not None, split)
        if stats is not None:
            stats.bad_data += split.bad
            stats.received += len(split.hot)
        return split

    @staticmethod
    def _decoded(datagrams: list[bytes], spec: HotSpec, keep_raw: bool) -> Split:
        split = decode_datagrams(datagrams, spec, keep_raw=keep_raw)
        _read_only(split.hot)
        return split

    def _sent_here(self, datagrams: list[bytes], spec: HotSpec) -> Split | None:
        """The split of `datagrams` if they hold the batch this process packed last, one run of the very
        objects, and nothing else of `spec` (else None: decode them all, the arrival order is theirs)."""
        packed = hot.last_packed
        if packed is None or packed.encoded.spec is not spec:
            return None
        run = packed.datagrams
        at = next((i for i, d in enumerate(datagrams) if d is run[0]), -1)
        if at < 0 or not all(map(operator.is_, run, datagrams[at:at + len(run)])):
            return None
        kept = self._packed
        if kept is None or kept[0] is not packed:
            kept = self._packed = (packed, _frames_of(packed.encoded))
        rest = decode_datagrams(datagrams[:at] + datagrams[at + len(run):], spec) if len(run) < len(datagrams) else None
        if rest is None:
            return Split(kept[1], [], 0)
        return None if len(rest.hot) else Split(kept[1], rest.others, rest.bad)


def _frames_of(encoded: hot.Encoded) -> HotFrames:
    """What decoding an encoded batch's frames gives, from the records they were packed from; read-only."""
    n, first = len(encoded.records), encoded.first_seq
    records = encoded.records.view()
    records.flags.writeable = False  # so are the field views taken from it
    return HotFrames(
        {f: records[f] for f in encoded.spec.fieldnames},
        np.frombuffer(bytes([encoded.system_id]) * n, np.uint8),
        np.frombuffer(bytes([encoded.component_id]) * n, np.uint8),
        np.frombuffer(bytes((first + k) & 0xFF for k in range(n)), np.uint8), encoded.frames,
    )


_EMPTY: dict[HotSpec, tuple[dict[str, np.ndarray], np.ndarray]] = {}


def _empty(spec: HotSpec, raw: list[bytes] | None) -> HotFrames:
    """No frames of `spec`: read-only columns, made once per spec (there is nothing in them to change)."""
    made = _EMPTY.get(spec)
    if made is None:
        rec = np.frombuffer(b"", spec.dtype)
        made = _EMPTY[spec] = ({f: rec[f] for f in spec.fieldnames}, np.frombuffer(b"", np.uint8))
    fields, none = made
    return HotFrames(fields, none, none, none, raw)


def _read_only(frames: HotFrames) -> None:
    if not len(frames):
        return  # `_empty`'s: read-only already
    for column in (*frames.fields.values(), frames.src_system, frames.src_component, frames.seq):
        column.flags.writeable = False


def _one_other_frame(gram: bytes, msg_id: bytes) -> bool:
    """Whether a datagram is one whole MAVLink 2 frame that is not a hot one: what `_walk` would hand on
    whole to `others` (most datagrams an aPad receives: a heartbeat, a command), told from its header."""
    return (len(gram) > 2 and gram[0] == MAGIC_V2
            and OVERHEAD + gram[1] + (SIGNATURE if gram[2] & mavlink.MAVLINK_IFLAG_SIGNED else 0) == len(gram)
            and not (gram[2] == 0 and gram[7:10] == msg_id))


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
            found = MAGIC.search(data, i + 1, n)
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
