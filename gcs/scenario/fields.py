"""Reading one table of a scenario file, field by field: the `Fields` interface and its checking side.

The reader of scenario data (`scenario.read_scenario`) asks a `Fields` table for each field by kind
(`number`, `integer`, `text`, `duration`, `file`, ...) with its default, range and choices. `FieldTable`
answers from a TOML table and refuses a bad value in one line; `scenario_schema.SchemaTable` answers
with a placeholder and records the field as JSON Schema. So the one reader is also the one description
of the format: the schema cannot drift from what the reader accepts.
"""

from __future__ import annotations

import difflib
import math
from pathlib import Path
from typing import Any, NamedTuple, Protocol

from missiontime.durations import parse_duration_s

REQUIRED: Any = object()  # the default of a field that must be given


class ScenarioError(ValueError):
    """One line for the user: file, field, what is wrong."""


class Derived(NamedTuple):
    """A default that depends on where the field is (the file's name, the aPad's place in the list):
    its value here, and in words for the schema."""

    value: Any
    about: str


def out_of_range(value: float, lo: float | None = None, hi: float | None = None) -> str | None:
    """Why `value` is not a finite number in [lo, hi], or None: the one range check for files and flags."""
    if not math.isfinite(value):
        return f"{value} is not a finite number"
    if lo is not None and hi is not None and not lo <= value <= hi:
        return f"{value} is outside [{lo}, {hi}]"
    if lo is not None and value < lo:
        return f"{value} is below {lo}"
    if hi is not None and value > hi:
        return f"{value} is above {hi}"
    return None


class Fields(Protocol):
    """One table of a scenario, read a field at a time. `default` is the value when the field is
    absent (`REQUIRED`: it must be given; a `Derived`: it depends on where the table is); `about`
    says what the field means, for the schema (editors show it)."""

    def fail(self, key: str, what: str) -> ScenarioError: ...

    def text(self, key: str, default: Any = None, choices: tuple[str, ...] | None = None, *,
             about: str = "") -> str:
        """A string, one of `choices` if given."""
        ...

    def number(self, key: str, default: Any = None, lo: float | None = None, hi: float | None = None, *,
               about: str = "") -> float: ...

    def integer(self, key: str, default: Any = None, lo: int | None = None, hi: int | None = None, *,
                about: str = "") -> int: ...

    def flag(self, key: str, default: bool = False, *, about: str = "") -> bool: ...

    def integers(self, key: str, lo: int, hi: int, *, about: str = "") -> tuple[int, ...]:
        """A list of distinct integers in [lo, hi] (default empty)."""
        ...

    def duration(self, key: str, default: Any = None, *, about: str = "") -> float:
        """Seconds, from a string with its unit ("90s", "40min", "1.5h", "7d"), up to 90 days."""
        ...

    def file(self, key: str, default: Any = None, *, about: str = "") -> Path | None:
        """An existing file, the path relative to the scenario file's folder."""
        ...

    def pair(self, key: str, default: Any = None, lo: float | None = None, hi: float | None = None, *,
             about: str = "") -> tuple[float, float]:
        """Two numbers [a, b], each in [lo, hi]."""
        ...

    def tables(self, key: str, *, about: str = "") -> list[Fields]:
        """`[key]` (one table) or `[[key]]` (an array of tables; named `key[i].field` in errors)."""
        ...

    def sub(self, key: str, *, about: str = "") -> Fields: ...

    def done(self) -> None:
        """Every field of the table has been read: any other is refused as unknown."""
        ...


class FieldTable:
    """`Fields` from one TOML table: typed, range-checked reads; leftovers are reported as unknown fields."""

    def __init__(self, path: Path, data: dict[str, Any], prefix: str) -> None:
        self.path, self.data, self.prefix = path, dict(data), prefix
        self.asked: list[str] = []  # the fields read so far: an unknown one is matched against them

    def fail(self, key: str, what: str) -> ScenarioError:
        return ScenarioError(f"{self.path}: {self.prefix}{key}: {what}")

    def _take(self, key: str, default: Any) -> Any:
        self.asked.append(key)
        if key in self.data:
            return self.data.pop(key)
        if default is REQUIRED:
            raise self.fail(key, "missing")
        return default.value if isinstance(default, Derived) else default

    def number(self, key: str, default: Any = None, lo: float | None = None, hi: float | None = None, *,
               about: str = "") -> float:
        value = self._take(key, default)
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.fail(key, f"expected a number, got {value!r}")
        problem = out_of_range(value, lo, hi)
        if problem:
            raise self.fail(key, problem)
        return float(value)

    def integer(self, key: str, default: Any = None, lo: int | None = None, hi: int | None = None, *,
                about: str = "") -> int:
        value = self._take(key, default)
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.fail(key, f"expected an integer, got {value!r}")
        problem = out_of_range(value, lo, hi)
        if problem:
            raise self.fail(key, problem)
        return value

    def text(self, key: str, default: Any = None, choices: tuple[str, ...] | None = None, *,
             about: str = "") -> str:
        value = self._take(key, default)
        if not isinstance(value, str):
            raise self.fail(key, f"expected a string, got {value!r}")
        if choices is not None and value not in choices:
            raise self.fail(key, f"{value!r} is not one of {', '.join(choices)}")
        return value

    def flag(self, key: str, default: bool = False, *, about: str = "") -> bool:
        value = self._take(key, default)
        if not isinstance(value, bool):
            raise self.fail(key, f"expected true or false, got {value!r}")
        return value

    def integers(self, key: str, lo: int, hi: int, *, about: str = "") -> tuple[int, ...]:
        value = self._take(key, [])
        if not isinstance(value, list) or not all(isinstance(v, int) and not isinstance(v, bool) for v in value):
            raise self.fail(key, f"expected a list of integers, got {value!r}")
        bad = [v for v in value if out_of_range(v, lo, hi)]
        if bad:
            raise self.fail(key, f"{bad[0]} is outside [{lo}, {hi}]")
        if len(set(value)) != len(value):
            raise self.fail(key, f"ids must differ, got {value}")
        return tuple(value)

    def duration(self, key: str, default: Any = None, *, about: str = "") -> float:
        value = self._take(key, default)
        try:
            return parse_duration_s(value)
        except ValueError as exc:
            raise self.fail(key, str(exc)) from None

    def file(self, key: str, default: Any = None, *, about: str = "") -> Path | None:
        value = self._take(key, default)
        if value is None:
            return None
        if not isinstance(value, str):
            raise self.fail(key, f"expected a file path, got {value!r}")
        resolved = (self.path.parent / value).resolve()
        if not resolved.is_file():
            raise self.fail(key, f"no such file: {resolved} (a path in a scenario is relative to the scenario "
                                 f"file's folder, {self.path.parent.resolve()})")
        return resolved

    def pair(self, key: str, default: Any = None, lo: float | None = None, hi: float | None = None, *,
             about: str = "") -> tuple[float, float]:
        value = self._take(key, default)
        if (
            not isinstance(value, list | tuple) or len(value) != 2
            or not all(isinstance(v, int | float) and not isinstance(v, bool) for v in value)
        ):
            raise self.fail(key, f"expected two numbers [a, b], got {value!r}")
        for v in value:
            problem = out_of_range(v, lo, hi)
            if problem:
                raise self.fail(key, problem)
        return float(value[0]), float(value[1])

    def tables(self, key: str, *, about: str = "") -> list[Fields]:
        value = self._take(key, {})
        if isinstance(value, dict):
            return [FieldTable(self.path, value, f"{self.prefix}{key}.")]
        if not isinstance(value, list) or not value or not all(isinstance(v, dict) for v in value):
            raise self.fail(key, "expected a table or an array of tables")
        return [FieldTable(self.path, v, f"{self.prefix}{key}[{i}].") for i, v in enumerate(value)]

    def sub(self, key: str, *, about: str = "") -> Fields:
        value = self._take(key, {})
        if not isinstance(value, dict):
            raise self.fail(key, "expected a table")
        return FieldTable(self.path, value, f"{self.prefix}{key}.")

    def done(self) -> None:
        for key in self.data:
            raise self.fail(key, f"unknown field{did_you_mean(key, self.asked, self.prefix)}")


def did_you_mean(given: str, known: list[str], prefix: str = "") -> str:
    """" (did you mean PREFIX.NAME?)" for the known name closest to a misspelt one (case aside), else ""."""
    by_lower = {k.lower(): k for k in known}
    close = difflib.get_close_matches(given.lower(), list(by_lower), n=1, cutoff=0.6)
    return f" (did you mean {prefix}{by_lower[close[0]]}?)" if close else ""
