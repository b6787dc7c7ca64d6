"""Regenerate the pymavlink module from `subcultron.xml` (MAVLink 2, validation and strict units on),
and its typed stub `subcultron.pyi`.

Run `python -m mavlink_dialect.generate`; `tests/unit/test_dialect.py` proves the committed module
and stub are exactly what this produces.

The stub is the one place pymavlink is typed for us. It is derived from the XML through
pymavlink's own parser (`mavparse`, the same objects mavgen reads), so every message class has its
fields with their Python types, and the fixed part (`MAVLink`, `MAVLink_message`, ...) declares
what the generated module defines. Types follow what the module does at run time:

- integer fields are `int`, float and double fields `float`;
- char arrays are passed to `__init__` as `bytes` and read back as `str` (the constructor cuts at
  the first NUL and decodes: that is also what a decoded message holds);
- other arrays are `Sequence[int]` / `Sequence[float]`: a decoded message holds a list, one built
  locally holds what it was given (extension defaults are tuples);
- what cannot be stated precisely is `Any`.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Any

from pymavlink.generator import mavgen, mavparse

HERE = Path(__file__).resolve().parent
XML_PATH = HERE / "subcultron.xml"
MODULE_PATH = HERE / "subcultron.py"
STUB_PATH = MODULE_PATH.with_suffix(".pyi")

WIRE_PROTOCOL = mavparse.PROTOCOL_2_0
LINE_LENGTH = 120  # the project's ruff line length; the stub is linted like our code

_SCALAR = {
    "float": "float",
    "double": "float",
    "int8_t": "int",
    "uint8_t": "int",
    "int16_t": "int",
    "uint16_t": "int",
    "int32_t": "int",
    "uint32_t": "int",
    "int64_t": "int",
    "uint64_t": "int",
}


def generate(xml_path: Path = XML_PATH, module_path: Path = MODULE_PATH) -> Path:
    """Write the generated Python 3 module for `xml_path` to `module_path` and its typed stub
    beside it (same name, `.pyi`); raise on invalid XML."""
    opts = mavgen.Opts(
        str(module_path), wire_protocol=WIRE_PROTOCOL, language="Python3", validate=True, strict_units=True
    )
    if not mavgen.mavgen(opts, [str(xml_path)]):
        raise RuntimeError(f"mavgen rejected {xml_path}")
    stub = module_path.with_suffix(".pyi")
    stub.write_text(render_stub(xml_path), encoding="utf-8")
    return module_path


# ---- reading the XML the way mavgen does -----------------------------------------------------------


def parse(xml_path: Path) -> list[Any]:
    """The `mavparse.MAVXML` documents of `xml_path` and everything it includes, in mavgen's order,
    with enums merged across files (each enum once, sorted, with its `_ENUM_END` entry)."""
    docs = [mavparse.MAVXML(str(xml_path), WIRE_PROTOCOL)]
    seen = {os.path.abspath(xml_path)}
    i = 0
    while i < len(docs):  # breadth first, like mavgen's expand_includes
        for include in docs[i].include:
            name = os.path.abspath(os.path.join(os.path.dirname(docs[i].filename), include))
            if name not in seen:
                seen.add(name)
                docs.append(mavparse.MAVXML(name, WIRE_PROTOCOL))
        i += 1
    if mavparse.check_duplicates(docs):  # also merges the enums, as it does for mavgen
        raise RuntimeError(f"duplicate message ids or fields in {xml_path} and its includes")
    return docs


# ---- the stub ----------------------------------------------------------------------------------------


def render_stub(xml_path: Path = XML_PATH) -> str:
    """The text of the typed stub for the module mavgen makes from `xml_path`."""
    docs = parse(xml_path)
    messages = [m for doc in docs for m in doc.message]
    enums = [e for doc in docs for e in doc.enum]
    names: set[str] = set(_FIXED_NAMES)
    out = [_HEADER.format(xml=Path(xml_path).name, files=", ".join(d.basename + ".xml" for d in docs)), _PREAMBLE]

    out.append("\n# enum entries (all enums, merged across the included files)\n")
    for enum in enums:
        out.append(f"\n# {enum.name}\n")
        for entry in enum.entry:
            if entry.name not in names:  # a name defined twice is one module attribute
                names.add(entry.name)
                out.append(f"{entry.name}: int\n")

    out.append("\n# message ids\n")
    for name in ["BAD_DATA", "UNKNOWN", *(m.name.upper() for m in messages)]:
        if f"MAVLINK_MSG_ID_{name}" not in names:
            names.add(f"MAVLINK_MSG_ID_{name}")
            out.append(f"MAVLINK_MSG_ID_{name}: int\n")

    for m in messages:
        out.append(_message_class(m))

    out.append("\nmavlink_map: dict[int, type[MAVLink_message]]\n")
    out.append(_MAVLINK_CLASS)
    for m in messages:
        out.append(_encode_and_send(m))
    return "".join(out)


def _attribute_type(field: Any) -> str:
    """What the message object holds after construction or decoding."""
    if field.type == "char":
        return "str"  # cut at the first NUL and decoded as ASCII by every constructor
    scalar = _SCALAR[field.type]
    if field.array_length == 1:
        return "Any"  # decoded as a scalar, but `pack` indexes it: no single type is right
    return f"Sequence[{scalar}]" if field.array_length else scalar


def _argument_type(field: Any) -> str:
    """What the constructor takes (`pack` uses it as is, or by index for arrays)."""
    if field.type == "char":
        return "bytes"  # the constructor splits it on b"\\x00"; a str raises TypeError
    scalar = _SCALAR[field.type]
    return f"Sequence[{scalar}]" if field.array_length else scalar


def _arguments(m: Any, encode: bool) -> list[str]:
    """The constructor's (or `<name>_encode`'s) arguments after self: extensions have defaults,
    and `<name>_encode` also fills in the constant `mavlink_version`."""
    args = []
    for i, f in enumerate(m.fields):
        default = (m.extensions_start is not None and i >= m.extensions_start) or (encode and f.omit_arg)
        args.append(f"{f.name}: {_argument_type(f)}" + (" = ..." if default else ""))
    return args


def _def(name: str, args: list[str], returns: str) -> str:
    """A stub method, on one line if it fits, else one argument per line."""
    line = f"    def {name}(self, {', '.join(args)}) -> {returns}: ..."
    if len(line) <= LINE_LENGTH:
        return line + "\n"
    body = "".join(f"        {a},\n" for a in ["self", *args])
    return f"    def {name}(\n{body}    ) -> {returns}: ...\n"


def _message_class(m: Any) -> str:
    lines = [f"\n\nclass MAVLink_{m.name.lower()}_message(MAVLink_message):\n"]
    for f in m.fields:
        units = f.units.strip("[]")
        lines.append(f"    {f.name}: {_attribute_type(f)}" + (f"  # {units}\n" if units else "\n"))
    lines.append(_def("__init__", _arguments(m, encode=False), "None"))
    return "".join(lines)


def _encode_and_send(m: Any) -> str:
    name = m.name.lower()
    args = _arguments(m, encode=True)
    return _def(f"{name}_encode", args, f"MAVLink_{name}_message") + _def(
        f"{name}_send", [*args, "force_mavlink1: bool = False"], "None"
    )


_HEADER = '''"""Typed stub for `subcultron.py`, the module mavgen generates from {xml}.

Generated by `python -m mavlink_dialect.generate` through pymavlink's `mavparse` from
{files}.
DO NOT EDIT: change the XML or mavlink_dialect/generate.py and regenerate.
"""

'''

# The part of the module mavgen writes the same for every dialect (pymavlink 2.4.50), typed from
# its source. `Any` where pymavlink's own annotation would be wrong (e.g. `to_dict` values can be
# lists) or no single type is right.
_PREAMBLE = '''\
import logging
import struct
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any, ClassVar, Protocol, TypeAlias, type_check_only

from typing_extensions import Buffer

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
'''

_FIXED_NAMES = frozenset(
    line.split(":")[0].split("(")[0].removeprefix("class ").strip()
    for line in _PREAMBLE.splitlines()
    if line and not line[0].isspace() and not line.startswith(("import ", "from ", "#"))
)

_MAVLINK_CLASS = '''

class MAVLink:
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
'''


def main() -> int:
    print(generate())
    return 0


if __name__ == "__main__":
    sys.exit(main())
