"""The part of every module mavgen generates that is the same whatever the dialect (pymavlink 2.4.50),
typed from pymavlink's source: a stub-only module, there is no `_pymavlink_base.py`.

The generated stub `subcultron.pyi` re-exports all of it and adds the dialect's own part (enum
entries, message ids, one class per message and `MAVLink` with its `<message>_encode` and
`<message>_send` methods on top of `_MAVLinkBase` here; it is imported back for the types that name
it). `Any` where pymavlink's own annotation would be wrong (e.g. `to_dict` values can be lists) or no
single type is right. Hand-written: keep it in step with pymavlink when it is upgraded.
"""

import logging
import struct
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any, ClassVar, Protocol, TypeAlias, type_check_only

from typing_extensions import Buffer

from mavlink_dialect.subcultron import MAVLink

WIRE_PROTOCOL_VERSION: str
DIALECT: str

PROTOCOL_MARKER_V1: int
PROTOCOL_MARKER_V2: int
HEADER_LEN_V1: int
HEADER_LEN_V2: int
MAVLINK_SIGNATURE_BLOCK_LEN: int
MAVLINK_IFLAG_SIGNED: int

logger: logging.Logger
MAVLINK_IGNORE_CRC: str | int  # the MAV_IGNORE_CRC environment variable, or 0

MAVLINK_TYPE_CHAR: int
MAVLINK_TYPE_UINT8_T: int
MAVLINK_TYPE_INT8_T: int
MAVLINK_TYPE_UINT16_T: int
MAVLINK_TYPE_INT16_T: int
MAVLINK_TYPE_UINT32_T: int
MAVLINK_TYPE_INT32_T: int
MAVLINK_TYPE_UINT64_T: int
MAVLINK_TYPE_INT64_T: int
MAVLINK_TYPE_FLOAT: int
MAVLINK_TYPE_DOUBLE: int

@type_check_only
class _Crc16(Protocol):  # only in the stub: the type of mcrf4xx
    def __call__(self, data: Buffer, initial: int | None = None) -> int: ...

mcrf4xx: _Crc16 | None  # fastcrc.crc16.mcrf4xx, None if fastcrc does not import

BytesLike: TypeAlias = list[int] | tuple[int, ...] | bytes | bytearray | str

class _x25crc_slow:
    crc: int
    def __init__(self, buf: BytesLike | None = None) -> None: ...
    def accumulate(self, buf: BytesLike) -> None: ...

class _x25crc_fast:
    crc: int
    def __init__(self, buf: BytesLike | None = None) -> None: ...
    def accumulate(self, buf: BytesLike) -> None: ...

x25crc: type[_x25crc_fast] | type[_x25crc_slow]

class MAVLink_header:
    mlen: int
    seq: int
    srcSystem: int
    srcComponent: int
    msgId: int
    incompat_flags: int
    compat_flags: int
    def __init__(
        self,
        msgId: int,
        incompat_flags: int = 0,
        compat_flags: int = 0,
        mlen: int = 0,
        seq: int = 0,
        srcSystem: int = 0,
        srcComponent: int = 0,
    ) -> None: ...
    def pack(self, force_mavlink1: bool = False) -> bytes: ...

class MAVLink_message:
    """Base of every message class; the generated subclasses set the class attributes."""

    id: int  # the message id (an instance's `id` field, where a message has one, shadows it)
    msgname: str
    fieldnames: list[str]
    ordered_fieldnames: list[str]
    fieldtypes: list[str]
    fielddisplays_by_name: dict[str, str]
    fieldenums_by_name: dict[str, str]
    fieldunits_by_name: dict[str, str]
    native_format: bytearray
    orders: list[int]
    lengths: list[int]
    array_lengths: list[int]
    crc_extra: int
    unpacker: struct.Struct
    instance_field: str | None
    instance_offset: int
    __hash__: ClassVar[None]  # type: ignore[assignment]  # defines __eq__ only: unhashable at run time
    def __init__(self, msgId: int, name: str) -> None: ...
    def format_attr(self, field: str) -> Any: ...
    def get_msgbuf(self) -> bytearray: ...
    def get_header(self) -> MAVLink_header: ...
    def get_payload(self) -> bytes | bytearray | None: ...
    def get_crc(self) -> int | None: ...
    def get_fieldnames(self) -> list[str]: ...
    def get_type(self) -> str: ...
    def get_msgId(self) -> int: ...
    def get_srcSystem(self) -> int: ...
    def get_srcComponent(self) -> int: ...
    def get_seq(self) -> int: ...
    def get_signed(self) -> bool: ...
    def get_link_id(self) -> int | None: ...
    def __eq__(self, other: object) -> bool: ...
    def __ne__(self, other: object) -> bool: ...
    def to_dict(self) -> dict[str, Any]: ...  # str, int, float or a list of them per field
    def to_json(self) -> str: ...
    def sign_packet(self, mav: MAVLink) -> None: ...
    def pack(self, mav: MAVLink, force_mavlink1: bool = False) -> bytes: ...
    def __getitem__(self, key: str) -> Any: ...

class mavlink_msg_deprecated_name_property:
    def __get__(self, instance: MAVLink_message | None, owner: type[MAVLink_message]) -> str: ...

class EnumEntry:
    name: str
    description: str
    param: dict[int, str]
    label: dict[int, str]
    has_location: bool
    def __init__(self, name: str, description: str) -> None: ...

class Enum(dict[int, EnumEntry]):
    bitmask: bool
    def __init__(self) -> None: ...

enums: dict[str, Enum]

class MAVError(Exception):
    message: str
    def __init__(self, msg: str) -> None: ...

class MAVLink_bad_data(MAVLink_message):
    data: bytes | bytearray
    reason: str
    def __init__(self, data: bytes | bytearray, reason: str) -> None: ...

class MAVLink_unknown(MAVLink_message):
    data: bytes | bytearray
    def __init__(self, msgid: int, data: bytes | bytearray) -> None: ...

class MAVLinkSigning:
    secret_key: bytes | None
    timestamp: int
    link_id: int
    sign_outgoing: bool
    allow_unsigned_callback: Callable[[MAVLink, int], bool] | None
    stream_timestamps: dict[tuple[int, int, int], int]
    sig_count: int
    badsig_count: int
    goodsig_count: int
    unsigned_count: int
    reject_count: int
    def __init__(self) -> None: ...

MAVLinkV1Header: TypeAlias = tuple[bytes, int, int, int, int, int]
MAVLinkV2Header: TypeAlias = tuple[bytes, int, int, int, int, int, int, int, int]

@type_check_only
class _MAVLinkBase:  # only in the stub: `MAVLink` at run time, less the methods per message
    """One MAVLink party's parser and encoder state."""

    seq: int
    file: Any  # whatever has the `write(bytes)` that `send` calls; None if unused
    srcSystem: int
    srcComponent: int
    callback: Callable[..., None] | None
    callback_args: Iterable[Any] | None
    callback_kwargs: Mapping[str, Any] | None
    send_callback: Callable[..., None] | None
    send_callback_args: Iterable[Any] | None
    send_callback_kwargs: Mapping[str, Any] | None
    buf: bytearray
    buf_index: int
    expected_length: int
    have_prefix_error: bool
    robust_parsing: bool
    protocol_marker: int
    little_endian: bool
    crc_extra: bool
    sort_fields: bool
    total_packets_sent: int
    total_bytes_sent: int
    total_packets_received: int
    total_bytes_received: int
    total_receive_errors: int
    startup_time: float
    signing: MAVLinkSigning
    mav20_unpacker: struct.Struct
    mav10_unpacker: struct.Struct
    mav20_h3_unpacker: struct.Struct
    mav_csum_unpacker: struct.Struct
    mav_sign_unpacker: struct.Struct
    def __init__(self, file: Any, srcSystem: int = 0, srcComponent: int = 0, use_native: bool = False) -> None: ...
    def set_callback(self, callback: Callable[..., None], *args: Any, **kwargs: Any) -> None: ...
    def set_send_callback(self, callback: Callable[..., None], *args: Any, **kwargs: Any) -> None: ...
    def send(self, mavmsg: MAVLink_message, force_mavlink1: bool = False) -> None: ...
    def buf_len(self) -> int: ...
    def bytes_needed(self) -> int: ...
    def parse_char(self, c: Sequence[int]) -> MAVLink_message | None: ...
    def parse_buffer(self, s: Sequence[int]) -> list[MAVLink_message] | None: ...
    def check_signature(self, msgbuf: bytearray, srcSystem: int, srcComponent: int) -> bool: ...
    def decode(self, msgbuf: bytearray) -> MAVLink_message: ...  # appends to slices of it: bytes fail
