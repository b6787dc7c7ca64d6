"""The JSON Schema of scenario files, written by running the one reader of scenario data on a recorder.

`SchemaTable` has the methods of `scenario_fields.Fields`: each read records the field (type, range,
choices, default, required, what it means) and answers with a value the reader accepts, so
`scenario.read_scenario` runs through once and the schema says what it asks for, nothing else.
What a schema cannot say stays with the reader alone: that files exist, min <= max, distinct aPad ids,
latitudes within +-90, finite numbers, durations up to 90 days; `vil scenario check` runs both.

The schema ships as gcs/scenario/scenario.schema.json (JSON Schema draft-07, within what Taplo's draft-4
support reads too); each shipped scenario names it on its first line, `#:schema ../gcs/mission/...`,
for TOML-aware editors (Taplo / Even Better TOML, Tombi). A test proves the shipped file is what
the reader makes today; to regenerate it:

    python -m gcs.scenario.schema --write
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import sys
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from jsonschema import Draft7Validator, validators
from jsonschema.exceptions import ValidationError, best_match

from gcs.scenario.fields import REQUIRED, Derived, Fields, ScenarioError, did_you_mean
from gcs.scenario.reader import read_scenario
from missiontime.durations import UNIT_S, parse_duration_s

SCHEMA_PATH = Path(__file__).with_name("scenario.schema.json")
SCHEMA_DIRECTIVE = "#:schema"  # a TOML file's first line names its schema so (Taplo, Tombi)
DRAFT = "http://json-schema.org/draft-07/schema#"
# A number and a unit, as missiontime.durations reads them (zero and more than 90 days: the reader refuses).
_UNITS = "|".join(sorted(UNIT_S, key=len, reverse=True))
DURATION_PATTERN = rf"^\s*(\d+(\.\d*)?|\.\d+)\s*({_UNITS})\s*$"
Schema = dict[str, Any]


class SchemaTable:
    """`Fields` that records JSON Schema: one table's properties, which of them are required, and
    whether other fields are refused (the reader said `done()`)."""

    def __init__(self, about: str = "") -> None:
        self.about = about
        self.properties: dict[str, Schema | SchemaTable | list[SchemaTable]] = {}  # a list: `[key]` or `[[key]]`
        self.required: list[str] = []
        self.closed = False

    def _field(self, key: str, default: Any, about: str, schema: Schema) -> None:
        if default is REQUIRED:
            self.required.append(key)
        elif isinstance(default, Derived):
            about = f"{about}; default: {default.about}" if about else f"default: {default.about}"
        elif default is not None:
            schema["default"] = list(default) if isinstance(default, tuple) else default
        self.properties[key] = ({"description": about} if about else {}) | schema

    def fail(self, key: str, what: str) -> ScenarioError:
        return ScenarioError(f"{key}: {what}")

    def text(self, key: str, default: Any = None, choices: tuple[str, ...] | None = None, *,
             about: str = "") -> str:
        self._field(key, default, about, {"type": "string"} | ({} if choices is None else {"enum": list(choices)}))
        return str(_given(default, choices[0] if choices else "x"))

    def number(self, key: str, default: Any = None, lo: float | None = None, hi: float | None = None, *,
               about: str = "") -> float:
        self._field(key, default, about, {"type": "number"} | _bounds(lo, hi))
        return float(_given(default, _inside(lo, hi)))

    def integer(self, key: str, default: Any = None, lo: int | None = None, hi: int | None = None, *,
                about: str = "") -> int:
        self._field(key, default, about, {"type": "integer"} | _bounds(lo, hi))
        return int(_given(default, _inside(lo, hi)))

    def flag(self, key: str, default: bool = False, *, about: str = "") -> bool:
        self._field(key, default, about, {"type": "boolean"})
        return bool(default)

    def integers(self, key: str, lo: int, hi: int, *, about: str = "") -> tuple[int, ...]:
        self._field(key, [], about, {"type": "array", "items": {"type": "integer"} | _bounds(lo, hi),
                                     "uniqueItems": True})
        return ()

    def duration(self, key: str, default: Any = None, *, about: str = "") -> float:
        about = f"{about}, with its unit: 90s, 40min, 1.5h" if about else "a duration with its unit: 90s, 40min, 1.5h"
        self._field(key, default, about, {"type": "string", "pattern": DURATION_PATTERN})
        return parse_duration_s(_given(default, "1s"))

    def file(self, key: str, default: Any = None, *, about: str = "") -> Path | None:
        where = "a path relative to this file's folder"
        self._field(key, default, f"{about} ({where})" if about else where, {"type": "string"})
        return Path(str(_given(default, "placeholder")))

    def pair(self, key: str, default: Any = None, lo: float | None = None, hi: float | None = None, *,
             about: str = "") -> tuple[float, float]:
        self._field(key, default, about, {"type": "array", "items": {"type": "number"} | _bounds(lo, hi),
                                          "minItems": 2, "maxItems": 2})
        a, b = _given(default, [_inside(lo, hi)] * 2)
        return float(a), float(b)

    def tables(self, key: str, *, about: str = "") -> list[Fields]:
        table = SchemaTable(about)
        self.properties[key] = [table]
        return [table]

    def sub(self, key: str, *, about: str = "") -> Fields:
        table = SchemaTable(about)
        self.properties[key] = table
        return table

    def done(self) -> None:
        self.closed = True

    def schema(self, definitions: dict[str, Schema], name: str = "") -> Schema:
        """This table as JSON Schema; an array-or-table field (`[[apad]]`) goes in `definitions` by its
        name and is referred to. A table is required when it has required fields: absent, it is empty."""
        out: Schema = ({"description": self.about} if self.about else {}) | {"type": "object"}
        properties: Schema = {}
        required = list(self.required)
        for key, field in self.properties.items():
            if isinstance(field, SchemaTable):
                properties[key] = field.schema(definitions, f"{name}{key}.")
            elif isinstance(field, list):
                (table,) = field
                definition = table.schema(definitions, f"{name}{key}.")
                definition.pop("description", None)  # said where it is used, beside the choice of forms
                definitions[f"{name}{key}"] = definition
                ref = {"$ref": f"#/definitions/{name}{key}"}
                properties[key] = ({"description": table.about} if table.about else {}) | {
                    "anyOf": [ref, {"type": "array", "items": ref, "minItems": 1}]}
                field = table
            else:
                properties[key] = field
            if isinstance(field, SchemaTable) and field.required:
                required.append(key)
        out["properties"] = properties
        if self.closed:  # before `required`: a misspelt field is named first, then the one it should be
            out["additionalProperties"] = False
        if required:
            out["required"] = sorted(required, key=list(self.properties).index)
        return out


def _given(default: Any, fallback: Any) -> Any:
    """The value the reader gets back: its own default, else one it accepts."""
    if isinstance(default, Derived):
        return default.value
    return fallback if default is None or default is REQUIRED else default


def _inside(lo: float | None, hi: float | None) -> float:
    """A value in [lo, hi] (the middle, when both are given)."""
    if lo is not None and hi is not None:
        return (lo + hi) / 2
    return lo if lo is not None else hi if hi is not None else 0


def _bounds(lo: float | None, hi: float | None) -> Schema:
    return ({} if lo is None else {"minimum": lo}) | ({} if hi is None else {"maximum": hi})


def scenario_schema() -> Schema:
    """The JSON Schema of scenario files, from the reader."""
    root = SchemaTable()
    read_scenario(root, Path("scenario.toml"))
    definitions: dict[str, Schema] = {}
    body = root.schema(definitions)
    return {
        "$schema": DRAFT,
        "title": "vil scenario",
        "description": "A mission run for vil (vil run FILE, vil gcs --scenario FILE); vil scenario check FILE "
                       "checks one against this schema and the reader (files exist, ranges hold together).",
    } | body | {"definitions": definitions}


def schema_text() -> str:
    """The schema file's text, as shipped."""
    return json.dumps(scenario_schema(), indent=2, ensure_ascii=False) + "\n"


# TOML tells 12 from 12.0 (JSON does not, so draft-07 takes 12.0 as an integer); the reader refuses 12.0.
_TomlValidator = validators.extend(Draft7Validator, type_checker=Draft7Validator.TYPE_CHECKER.redefine(
    "integer", lambda _checker, value: isinstance(value, int) and not isinstance(value, bool)))


@functools.cache
def _validator() -> Any:
    return _TomlValidator(json.loads(SCHEMA_PATH.read_text(encoding="utf-8")))


def schema_problems(data: dict[str, Any]) -> list[str]:
    """What the shipped schema refuses in a scenario's parsed TOML: one "field: what" line each, the
    field named by its path (`fleet.cuont: unknown field`, `apad[1].home: ...`)."""
    return [line for error in _validator().iter_errors(data) for line in _describe(error)]


def directive_problem(path: Path) -> str | None:
    """Why the file's `#:schema PATH` line (relative to its folder) does not lead an editor to the shipped
    schema, as one line; None when it does, when it names a URL, or when there is no such line (a copy of a
    shipped scenario carries `#:schema ../gcs/...`, which points nowhere from another folder)."""
    try:
        with path.open(encoding="utf-8") as f:
            first = f.readline().strip()
    except (OSError, UnicodeDecodeError):
        return None  # the reader says why the file cannot be read
    if not first.startswith(SCHEMA_DIRECTIVE):
        return None
    target = first[len(SCHEMA_DIRECTIVE):].strip()
    if "://" in target:
        return None
    named = (path.parent / target).resolve()
    if named == SCHEMA_PATH.resolve() or (named.is_file() and named.read_bytes() == SCHEMA_PATH.read_bytes()):
        return None
    why = "is not the shipped schema" if named.is_file() else "points nowhere"
    return (f"{path}: warning: {SCHEMA_DIRECTIVE} {target} {why} from this file's folder; editors find the "
            f"schema with {SCHEMA_DIRECTIVE} {os.path.relpath(SCHEMA_PATH.resolve(), path.parent.resolve())}")


def _describe(error: ValidationError) -> list[str]:
    path = _dotted(error.absolute_path)
    if error.context:  # `[apad]` or `[[apad]]`: the error of the form that came closest, or neither form
        types = [e.validator_value for e in error.context if e.validator == "type" and not e.relative_path]
        if len(types) == len(error.context):
            return [f"{path}: {error.instance!r} is not of type {' or '.join(map(repr, types))}"]
        error = best_match([error])
        path = _dotted(error.absolute_path)
    if error.validator == "additionalProperties":
        known = error.schema.get("properties", {})
        table = _dotted(error.absolute_path)
        prefix = f"{table}." if table else ""
        return [f"{prefix}{k}: unknown field{did_you_mean(k, list(known), prefix)}"
                for k in error.instance if k not in known]
    if error.validator == "required":
        return [f"{_dotted([*error.absolute_path, k])}: missing" for k in error.validator_value
                if k not in error.instance]
    if error.validator == "pattern" and "description" in error.schema:
        return [f"{path}: {error.instance!r}: expected {error.schema['description']}"]
    return [f"{path or '(the file)'}: {error.message}"]


def _dotted(path: Iterable[str | int]) -> str:
    """["apad", 1, "home"] as apad[1].home."""
    return "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in path).lstrip(".")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m gcs.scenario.schema",
                                     description="Print the JSON Schema of scenario files (--write: into "
                                                 f"{SCHEMA_PATH.name}, shipped in the package).")
    parser.add_argument("--write", action="store_true", help=f"write {SCHEMA_PATH} instead of printing it")
    args = parser.parse_args(argv)
    if args.write:
        SCHEMA_PATH.write_text(schema_text(), encoding="utf-8")
        print(f"wrote {SCHEMA_PATH}")
    else:
        sys.stdout.write(schema_text())
    return 0


if __name__ == "__main__":
    sys.exit(main())
