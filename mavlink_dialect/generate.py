"""Regenerate the pymavlink module from `subcultron.xml` (MAVLink 2, validation and strict units on).

Run `python -m mavlink_dialect.generate`; `tests/unit/test_dialect_generated.py` proves the
committed module is exactly what this produces.
"""

from __future__ import annotations

import sys
from pathlib import Path

from pymavlink.generator import mavgen

HERE = Path(__file__).resolve().parent
XML_PATH = HERE / "subcultron.xml"
MODULE_PATH = HERE / "subcultron.py"


def generate(xml_path: Path = XML_PATH, module_path: Path = MODULE_PATH) -> Path:
    """Write the generated Python 3 module for `xml_path` to `module_path`; raise on invalid XML."""
    opts = mavgen.Opts(
        str(module_path), wire_protocol="2.0", language="Python3", validate=True, strict_units=True
    )
    if not mavgen.mavgen(opts, [str(xml_path)]):
        raise RuntimeError(f"mavgen rejected {xml_path}")
    return module_path


def main() -> int:
    print(generate())
    return 0


if __name__ == "__main__":
    sys.exit(main())
