"""The subCULTron MAVLink dialect, its codec and the byte transports every MAVLink party uses.

`mavlink` is the module mavgen generated from `subcultron.xml` (common.xml included). The
dialect's enums carry the models' vocabulary on the wire (`mussel_sim.vocabulary`,
`apad_sitl.vocabulary` own the names; tests/unit/test_dialect.py holds the values together).
"""

from __future__ import annotations

from mavlink_dialect import subcultron as mavlink
from mavlink_dialect.codec import Codec, CodecStats
from mavlink_dialect.transport import (
    AddressError,
    MemoryTransport,
    Transport,
    memory_pair,
    open_transport,
)

MAV_CMD_APAD_DOCK: int = mavlink.MAV_CMD_APAD_DOCK
MAV_CMD_APAD_UNDOCK: int = mavlink.MAV_CMD_APAD_UNDOCK

__all__ = [
    "MAV_CMD_APAD_DOCK",
    "MAV_CMD_APAD_UNDOCK",
    "AddressError",
    "Codec",
    "CodecStats",
    "MemoryTransport",
    "Transport",
    "mavlink",
    "memory_pair",
    "open_transport",
]
