"""One MAVLink party's encoder and parser: its ids, sequence numbers, signing and error counts."""

from __future__ import annotations

import operator
import struct
from collections.abc import Callable, Collection
from dataclasses import dataclass
from typing import Any

from mavlink_dialect import signing
from mavlink_dialect import subcultron as mavlink

if mavlink.mcrf4xx is None:  # pragma: no cover - pymavlink requires fastcrc
    raise ImportError("mavlink_dialect needs fastcrc (pymavlink's CRC)")
crc16 = mavlink.mcrf4xx  # CRC-16/MCRF4XX, pymavlink's own choice

HEADER_V2_LEN = mavlink.HEADER_LEN_V2
CRC_LEN = 2


@dataclass
class CodecStats:
    """Counters a field engineer reads when a link misbehaves."""

    sent: int = 0
    received: int = 0
    bad_data: int = 0  # garbage, truncated or CRC-broken frames, refused signatures
    unknown: int = 0  # well-formed frames with a message id the dialect does not know


class Codec:
    """Encodes messages as MAVLink 2 frames from one (system, component) and parses incoming bytes.

    The parser keeps partial frames between calls, so it serves datagrams and byte streams alike.
    Bad and unknown frames are counted and dropped, never raised.
    """

    def __init__(self, system_id: int, component_id: int) -> None:
        self.mav = mavlink.MAVLink(None, srcSystem=system_id, srcComponent=component_id)
        self.mav.robust_parsing = True
        self.stats = CodecStats()

    @property
    def system_id(self) -> int:
        return int(self.mav.srcSystem)

    @property
    def component_id(self) -> int:
        return int(self.mav.srcComponent)

    def encode(self, msg: mavlink.MAVLink_message) -> bytes:
        """Pack `msg` with this party's ids and the next sequence number."""
        mav = self.mav
        plain = _PLAIN.get(type(msg)) if not mav.signing.sign_outgoing else None
        if plain is None:
            buf = bytes(msg.pack(mav))
        else:  # what msg.pack does, without its generic steps (a third of the time)
            payload = plain.unpacker.pack(*plain.values(msg))
            cut = payload.rstrip(b"\0") or payload[:1]
            buf = frame(plain.msg_id, plain.crc_extra, cut, mav.seq, mav.srcSystem, mav.srcComponent)
            packed: Any = msg  # what pymavlink's _pack leaves on the message (the stub leaves them out)
            # pymavlink's message keeps its packed form in private fields and has no public setter for them.
            packed._payload = cut  # noqa: SLF001
            packed._header = mavlink.MAVLink_header(plain.msg_id, 0, 0, len(cut), mav.seq,  # noqa: SLF001
                                                    mav.srcSystem, mav.srcComponent)
            packed._msgbuf = bytearray(buf)  # noqa: SLF001
            packed._crc = buf[-2] | buf[-1] << 8  # noqa: SLF001
        mav.seq = (mav.seq + 1) % 256
        self.stats.sent += 1
        return buf

    def next_seq(self, n: int) -> int:
        """Take `n` consecutive sequence numbers for frames packed elsewhere (`hot`); returns the first."""
        first = int(self.mav.seq)
        self.mav.seq = (first + n) % 256
        self.stats.sent += n
        return first

    def enable_signing(
        self, key: bytes, link_id: int, ticks: Callable[[], int], allow_unsigned_ids: Collection[int] = ()
    ) -> None:
        """Sign what we send (timestamps from `ticks`, see `signing`) and refuse unsigned or forged frames."""
        signing.configure(self.mav, key, link_id, allow_unsigned_ids)
        self._ticks = ticks
        self.encode = self._encode_signed  # type: ignore[method-assign]  # unsigned codecs pay nothing

    def _encode_signed(self, msg: mavlink.MAVLink_message) -> bytes:
        s = self.mav.signing
        s.timestamp = max(s.timestamp, self._ticks())  # never behind the clock, never backwards
        return Codec.encode(self, msg)

    @property
    def signing(self) -> bool:
        """True once `enable_signing` was called: unsigned frames are refused (but allowed ids)."""
        return self.mav.signing.secret_key is not None

    @property
    def signing_rejects(self) -> int:
        """Frames refused for a missing, wrong or replayed signature (also counted in bad_data)."""
        return int(self.mav.signing.reject_count)

    @property
    def signing_refusals(self) -> dict[str, int]:
        """`signing_rejects` by reason: unsigned, replay, stale_stream, bad_signature."""
        s: Any = self.mav.signing  # `signing.configure` added the counter pymavlink lacks
        if s.secret_key is None:
            return {}
        refused = dict(s.refused)
        unsigned = max(int(s.reject_count) - sum(refused.values()), 0)
        return {"unsigned": unsigned, **refused} if unsigned else refused

    def decode(self, data: bytes) -> list[mavlink.MAVLink_message]:
        """Every complete, valid message in `data` (plus what earlier calls left buffered)."""
        if self.mav.buf_len() == 0 and _single_v2_frame(data):
            # One whole frame per datagram is the common case: skip pymavlink's byte-stream
            # state machine (a quarter of the parse time) and let its decode check the rest.
            plain = _PLAIN_IDS.get(data[7] | data[8] << 8 | data[9] << 16) if data[2] == 0 else None
            if plain is not None and self.mav.signing.secret_key is None:
                msg = plain.decode(data)
                if msg is None:
                    self.stats.bad_data += 1
                    return []
                self.stats.received += 1
                return [msg]
            try:
                msgs = [self.mav.decode(bytearray(data))]
            except mavlink.MAVError:
                self.stats.bad_data += 1
                return []
        else:
            msgs = self.mav.parse_buffer(data) or []
        good = []
        for msg in msgs:
            msg_id = msg.get_msgId()
            if msg_id == mavlink.MAVLINK_MSG_ID_BAD_DATA:
                self.stats.bad_data += 1
            elif msg_id == mavlink.MAVLINK_MSG_ID_UNKNOWN:
                self.stats.unknown += 1
            else:
                good.append(msg)
        self.stats.received += len(good)
        return good


def frame(msg_id: int, crc_extra: int, payload: bytes, seq: int, system_id: int, component_id: int) -> bytes:
    """An unsigned MAVLink 2 frame around `payload` (trailing zeros already cut), as pymavlink packs it."""
    body = _HEADER.pack(mavlink.PROTOCOL_MARKER_V2, len(payload), 0, 0, seq, system_id, component_id,
                        msg_id & 0xFFFF, msg_id >> 16) + payload
    return body + crc16(bytes([crc_extra]), crc16(body[1:])).to_bytes(2, "little")


_HEADER = struct.Struct("<BBBBBBBHB")  # MAVLink_header.pack's layout


class _Plain:
    """A message of scalar fields only (no arrays, no strings): packed and parsed here with its own
    struct, byte for byte and object for object what pymavlink's generic pack and decode give
    (tests/unit/test_codec.py compares both on every such message of the dialect)."""

    def __init__(self, cls: type[mavlink.MAVLink_message]) -> None:
        self.cls, self.msg_id, self.crc_extra = cls, int(cls.id), int(cls.crc_extra)
        self.unpacker: struct.Struct = cls.unpacker
        names = cls.ordered_fieldnames
        getter = operator.attrgetter(*names)
        self.values: Callable[[Any], tuple[Any, ...]] = getter if len(names) > 1 else lambda m: (getter(m),)
        self.orders = cls.orders
        self.extra = bytes([self.crc_extra])

    @staticmethod
    def of(cls: type[mavlink.MAVLink_message]) -> _Plain | None:
        if any(cls.array_lengths) or "s" in cls.unpacker.format or "c" in cls.unpacker.format:
            return None
        return _Plain(cls)

    def decode(self, data: bytes) -> mavlink.MAVLink_message | None:
        """One whole unsigned frame of this message (checked by the caller); None if its CRC is wrong."""
        crc = data[-2] | data[-1] << 8
        if crc16(self.extra, crc16(data[1:-2])) != crc:
            return None
        size = self.unpacker.size
        payload = data[HEADER_V2_LEN:-2]
        if len(payload) != size:  # zeros cut by the sender come back; a longer one is cut (pymavlink's rule)
            payload = payload.ljust(size, b"\0")[:size]
        t = self.unpacker.unpack(payload)
        msg: Any = self.cls(*[t[i] for i in self.orders])  # Any: the stub leaves pymavlink's private fields out
        # What pymavlink's decode leaves in the message's private fields (it has no public setter for them).
        msg._signed = False  # noqa: SLF001
        msg._msgbuf = buf = bytearray(data)  # noqa: SLF001
        msg._payload = buf[6:-2]  # noqa: SLF001  # sic: pymavlink's decode takes [6:], a MAVLink 1 header's length
        msg._crc = crc  # noqa: SLF001
        msg._header = mavlink.MAVLink_header(self.msg_id, 0, 0, data[1], data[4], data[5], data[6])  # noqa: SLF001
        return msg


_PLAIN: dict[type[mavlink.MAVLink_message], _Plain] = {}
if not mavlink.MAVLINK_IGNORE_CRC:  # pymavlink told to accept bad CRCs: its own decode does that
    _PLAIN = {cls: plain for cls in mavlink.mavlink_map.values() if (plain := _Plain.of(cls)) is not None}
_PLAIN_IDS = {plain.msg_id: plain for plain in _PLAIN.values()}


def _single_v2_frame(data: bytes) -> bool:
    """True if `data` is exactly one MAVLink 2 frame: magic, known flags, length that fits."""
    if len(data) < HEADER_V2_LEN + CRC_LEN or data[0] != mavlink.PROTOCOL_MARKER_V2:
        return False
    flags = data[2]
    if flags & ~mavlink.MAVLINK_IFLAG_SIGNED:
        return False  # unknown incompatibility flags: let the robust parser reject it
    signature = mavlink.MAVLINK_SIGNATURE_BLOCK_LEN if flags & mavlink.MAVLINK_IFLAG_SIGNED else 0
    return len(data) == HEADER_V2_LEN + data[1] + CRC_LEN + signature
