"""One MAVLink party's encoder and parser: its ids, sequence numbers, signing and error counts."""

from __future__ import annotations

from collections.abc import Callable, Collection
from dataclasses import dataclass
from typing import Any

from mavlink_dialect import signing
from mavlink_dialect import subcultron as mavlink

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
        buf = msg.pack(self.mav)
        self.mav.seq = (self.mav.seq + 1) % 256
        self.stats.sent += 1
        return bytes(buf)

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


def _single_v2_frame(data: bytes) -> bool:
    """True if `data` is exactly one MAVLink 2 frame: magic, known flags, length that fits."""
    if len(data) < HEADER_V2_LEN + CRC_LEN or data[0] != mavlink.PROTOCOL_MARKER_V2:
        return False
    flags = data[2]
    if flags & ~mavlink.MAVLINK_IFLAG_SIGNED:
        return False  # unknown incompatibility flags: let the robust parser reject it
    signature = mavlink.MAVLINK_SIGNATURE_BLOCK_LEN if flags & mavlink.MAVLINK_IFLAG_SIGNED else 0
    return len(data) == HEADER_V2_LEN + data[1] + CRC_LEN + signature
