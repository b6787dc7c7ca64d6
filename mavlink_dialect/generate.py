"""Regenerate the pymavlink module from `subcultron.xml` (MAVLink 2, validation and strict units on),
and its typed stub `subcultron.pyi`.

Run `python -m mavlink_dialect.generate`; `tests/unit/test_dialect.py` proves the committed module
and stub are exactly what this produces.

The stub is the one place pymavlink is typed for us. It is derived from the XML through
pymavlink's own parser (`mavparse`, the same objects mavgen reads), so every message class has its
description and its fields with their Python types. The part of the module that is the same for
every dialect (`MAVLink_message`, `x25crc`, the state of `MAVLink`, ...) is typed once, by hand, in
the stub-only module `_pymavlink_base.pyi`, which the stub re-exports. Types follow what the module
does at run time:

- integer fields are `int`, float and double fields `float`;
- char arrays are passed to `__init__` as `bytes` and read back as `str` (the constructor cuts at
  the first NUL and decodes: that is also what a decoded message holds);
- other arrays are `Sequence[int]` / `Sequence[float]`: a decoded message holds a list, one built
  locally holds what it was given (extension defaults are tuples);
- what cannot be stated precisely is `Any`.
"""

from __future__ import annotations

import ast
import os
import sys
import textwrap
from pathlib import Path
from typing import Any

from pymavlink.generator import mavgen, mavparse

HERE = Path(__file__).resolve().parent
XML_PATH = HERE / "subcultron.xml"
MODULE_PATH = HERE / "subcultron.py"
STUB_PATH = MODULE_PATH.with_suffix(".pyi")
BASE_STUB_PATH = HERE / "_pymavlink_base.pyi"  # the fixed part, imported by the stub

WIRE_PROTOCOL = mavparse.PROTOCOL_2_0
LINE_LENGTH = 120  # the project's line length, for the docstrings in the stub

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
    names = _fixed_names()
    out = [_HEADER.format(xml=Path(xml_path).name, files=", ".join(d.basename + ".xml" for d in docs))]

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


def _fixed_names(base_stub: Path = BASE_STUB_PATH) -> set[str]:
    """The names the fixed part defines (an enum entry or message id of the same name is not declared
    again: the module has it once)."""
    names: set[str] = set()
    for node in ast.parse(base_stub.read_text(encoding="utf-8")).body:
        if isinstance(node, ast.ClassDef):
            names.add(node.name)
        elif isinstance(node, ast.AnnAssign | ast.Assign):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            names.update(t.id for t in targets if isinstance(t, ast.Name))
    return names


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


# The stub is compact: a message class is its description, its fields on one line and `__init__` on
# one line, and each method of `MAVLink` is one line, whatever the length (ruff does not lint the
# generated stub). One field or argument a line made hundreds of classes of the same shape.


def _def(name: str, args: list[str], returns: str) -> str:
    """A stub method on one line."""
    return f"    def {name}({', '.join(['self', *args])}) -> {returns}: ...\n"


def _docstring(text: str) -> str:
    """The XML's description as a docstring, wrapped to the project's line length."""
    text = " ".join(text.split()).replace("\\", "\\\\").replace('"', '\\"') or "(no description)"
    lines = textwrap.wrap(f'"""{text}"""', LINE_LENGTH - 4, break_long_words=False, break_on_hyphens=False)
    return "".join(f"    {line}\n" for line in lines)


def _units(fields: list[Any]) -> str:
    """A comment with the fields' units, `  # a, b: m; c: rad/s`, or nothing if none has one."""
    by_unit: dict[str, list[str]] = {}
    for f in fields:
        if f.units:
            by_unit.setdefault(f.units.strip("[]"), []).append(f.name)
    return "  # " + "; ".join(f"{', '.join(names)}: {unit}" for unit, names in by_unit.items()) if by_unit else ""


def _message_class(m: Any) -> str:
    fields = "; ".join(f"{f.name}: {_attribute_type(f)}" for f in m.fields)
    head = f"\n\nclass MAVLink_{m.name.lower()}_message(MAVLink_message):\n" + _docstring(m.description)
    body = f"    {fields}{_units(m.fields)}\n" if fields else ""
    return head + body + _def("__init__", _arguments(m, encode=False), "None")


def _encode_and_send(m: Any) -> str:
    name, args = m.name.lower(), _arguments(m, encode=True)
    send = _def(f"{name}_send", [*args, "force_mavlink1: bool = False"], "None")
    return _def(f"{name}_encode", args, f"MAVLink_{name}_message") + send


_HEADER = '''"""Typed stub for `subcultron.py`, the module mavgen generates from {xml}.

Generated by `python -m mavlink_dialect.generate` through pymavlink's `mavparse` from
{files}. The part that is the same for every dialect is in `_pymavlink_base.pyi`.
DO NOT EDIT: change the XML or mavlink_dialect/generate.py and regenerate.
"""

from collections.abc import Sequence
from typing import Any

from mavlink_dialect._pymavlink_base import *
from mavlink_dialect._pymavlink_base import _MAVLinkBase
from mavlink_dialect._pymavlink_base import _x25crc_fast as _x25crc_fast, _x25crc_slow as _x25crc_slow
'''

_MAVLINK_CLASS = '''

class MAVLink(_MAVLinkBase):
    """One MAVLink party's parser and encoder state, with a `<message>_encode` and `_send` per message."""

'''


def main() -> int:
    print(generate())
    return 0


if __name__ == "__main__":
    sys.exit(main())
