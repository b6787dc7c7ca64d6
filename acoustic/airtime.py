"""The nanomodem v3's packets in time (its user guide v3.2; NOTES.md "Underwater acoustics").

A command or ping packet lasts 0.105 s (a 30 ms frame header and a 75 ms message header); a data
packet of n payload bytes lasts 0.105 + (n + 16) x 0.0125 s: 16 bytes of error correction travel
with every payload, up to 8 of the n + 16 bytes can be corrected. Payloads are 2 to 64 bytes.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

HEADER_S = 0.105  # frame header 30 ms + message header 75 ms: a ping or command packet
BYTE_S = 0.0125  # one coded byte at 640 bit/s
FEC_BYTES = 16  # error-correction bytes sent with each payload
CORRECTABLE_BYTES = 8  # of the n + FEC_BYTES coded bytes, up to this many can be wrong
MIN_PAYLOAD = 2
MAX_PAYLOAD = 64
PING_TIMEOUT_S = 4.0  # a ping (or an acknowledged unicast) unanswered this long: "#TO"
RANGE_TICK_S = 3.125e-5  # the ranging counter's tick: range = ticks x c x 3.125e-5 (4.7 cm at 1500 m/s)


def data_airtime_s(payload_bytes: ArrayLike) -> NDArray[np.float64]:
    """Seconds on the water of data packets of `payload_bytes` (each 2..64; ValueError otherwise)."""
    n = np.asarray(payload_bytes, dtype=np.int64)
    if np.any((n < MIN_PAYLOAD) | (n > MAX_PAYLOAD)):
        raise ValueError(f"payload must be {MIN_PAYLOAD}..{MAX_PAYLOAD} bytes, got {n}")
    return np.asarray(HEADER_S + (n + FEC_BYTES) * BYTE_S, dtype=np.float64)


def airtime_s(payload_bytes: int) -> float:
    """One packet's airtime: 0 payload bytes is a ping or command packet (HEADER_S)."""
    return HEADER_S if payload_bytes == 0 else float(data_airtime_s(payload_bytes))
