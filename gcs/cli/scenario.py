"""`vil scenario`: check scenario files, or write a new one from an area.

    vil scenario check missions/*.toml mine.toml    # per file: ok and what it holds, or a line per error
    vil scenario new bay.geojson --count 30 -o mybay.toml                 # one aPad in the area's middle
    vil scenario new bay.geojson --count 30 --apad 43.939,15.4397 --apad 43.9387,15.4391 -o mybay.toml

`check` validates each file against the scenario schema (gcs/scenario/scenario.schema.json, which
TOML-aware editors read from a file's first line, `#:schema PATH`), then reads it as `vil run` does:
the reader also checks what a schema cannot say (the files it names exist and hold an area and a
fleet, start_battery's min <= max, distinct aPad ids, latitudes within +-90).

`new` writes a scenario of --count N aMussels in AREA (GeoJSON) served by one aPad per --apad LAT,LON
(a negative latitude: --apad=-33.86,151.21), paths written relative to the new file's folder; every
other field takes its default (the schema lists them). The file is checked as `check` does before it
is written, and an existing one is kept unless --force.

Exit status: 0 every file is good (or was written); 2 a file has errors, or bad input (one line each).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
import tomllib
from pathlib import Path
from typing import Any

from gcs.scenario.model_params import check_inputs
from gcs.scenario.reader import Scenario, ScenarioError, load_scenario, read_toml, resolve_scenario, scenario_from_data
from gcs.scenario.schema import SCHEMA_DIRECTIVE, SCHEMA_PATH, directive_problem, schema_problems
from mussel_sim.placement import load_area

EXIT_BAD = 2
# A field of the written file, as the flag of `new` that gave it (a refusal names the flag).
_FLAGS = ((r"fleet\.count", "--count"), (r"fleet\.area", "AREA"), (r"scenario\.name", "--name"),
          (r"apad(\[\d+\])?\.home", "--apad"))


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    check = sub.add_parser("check", help="check scenario files against the schema and the reader",
                           description="Check each scenario file: the schema, then the reader as vil run reads it.")
    check.add_argument("files", nargs="+", metavar="FILE", help="scenario files (TOML), or names in missions/")
    new = sub.add_parser("new", help="write a scenario from an area, a fleet count and aPad homes",
                         description="Write a scenario file that vil scenario check and vil run accept: N aMussels "
                                     "in AREA, an aPad at each --apad home; the other fields take their defaults.")
    new.add_argument("area", type=Path, metavar="AREA", help="the aMussels' area (GeoJSON polygon)")
    new.add_argument("--count", type=int, required=True, metavar="N", help="simulated aMussels (1 .. 65535)")
    new.add_argument("--apad", type=_lat_lon, action="append", metavar="LAT,LON",
                     help="an aPad's home in degrees, once per aPad; a negative latitude: --apad=-33.86,151.21 "
                          "(default: one aPad in the area's middle)")
    new.add_argument("--name", help="the scenario's name (default: the file's name without .toml)")
    new.add_argument("-o", "--out", type=Path, required=True, metavar="FILE", help="the scenario file to write")
    new.add_argument("--force", action="store_true", help="overwrite FILE if it exists")


def run(args: argparse.Namespace) -> int:
    if args.action == "check":
        return max(_check(name) for name in args.files)
    try:
        written = _new(args.area, args.count, args.apad, args.name, args.out, args.force)
    except ScenarioError as exc:
        print(f"vil scenario new: {exc}", file=sys.stderr)
        return EXIT_BAD
    print(f"{written}: written; vil run {written} runs it")
    return 0


def _check(name: str) -> int:
    """One line: the file is ok and what it holds, or a line per error (exit status 2)."""
    try:
        path = resolve_scenario(name)
        problems = [f"{path}: {line}" for line in schema_problems(read_toml(path))]
        if not problems:  # the schema's refusals are the reader's too: each said once
            scenario = load_scenario(path)
            check_inputs(scenario)
            print(f"{path}: ok: {_summary(scenario)}")
            warning = directive_problem(path)
            if warning:  # the file runs; only an editor's help is lost
                print(warning, file=sys.stderr)
            return 0
    except ScenarioError as exc:
        problems = [str(exc)]
    for line in problems:
        print(line, file=sys.stderr)
    return EXIT_BAD


def _summary(s: Scenario) -> str:
    apads = f"{len(s.apads)} aPad" + ("s" if len(s.apads) > 1 else "")
    return f"{s.name}, {s.fleet.count} aMussels, {apads}, {s.mission.duration_s / 60:g} min"


def _lat_lon(text: str) -> tuple[float, float]:
    lat, sep, lon = text.partition(",")
    try:
        if not sep:
            raise ValueError
        return float(lat), float(lon)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected LAT,LON in degrees, e.g. 43.94,15.44, got {text!r}") from None


def _new(area: Path, count: int, homes: list[tuple[float, float]] | None, name: str | None, out: Path,
         force: bool) -> Path:
    """Write the scenario, checked first by the schema and the reader; ScenarioError (one line) if not."""
    if out.exists() and not force:
        raise ScenarioError(f"{out} exists (--force overwrites it)")
    if not out.parent.is_dir():
        raise ScenarioError(f"{out}: no such folder {out.parent}")
    if not area.is_file():
        raise ScenarioError(f"AREA {area}: no such file")
    folder = out.parent.resolve()
    data: dict[str, Any] = {
        "scenario": {"name": name or out.stem, "seed": 1},
        "fleet": {"count": count, "area": _relative(area, folder)},
    }
    apads = [{"system_id": i + 1, "home": list(h)} for i, h in enumerate(homes or [_middle(area)])]
    data["apad"] = apads[0] if len(apads) == 1 else apads
    try:
        problems = schema_problems(data)
        if problems:
            raise ScenarioError(f"{out}: {problems[0]}")
        check_inputs(scenario_from_data(out, data))  # paths taken from `out`'s folder, as when it is read
    except ScenarioError as exc:
        raise ScenarioError(_as_flag(str(exc), out)) from None
    text = _render(data, _relative(SCHEMA_PATH, folder))
    if tomllib.loads(text) != data:  # the TOML writer is ours: what it writes must read back as checked
        raise AssertionError(f"the scenario written does not read back as checked:\n{text}")
    _write(out, text)
    return out


def _write(out: Path, text: str) -> None:
    """All of `text` in `out`, or nothing: written beside it (with the umask's permissions), then moved over it."""
    tmp = out.with_name(f".{out.name}.{os.getpid()}.tmp")
    try:
        with tmp.open("x", encoding="utf-8") as f:
            f.write(text)
        os.replace(tmp, out)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise ScenarioError(f"cannot write {out}: {exc.strerror or exc}") from None


def _middle(area: Path) -> tuple[float, float]:
    """The area's centroid as (lat, lon), or a point inside it where the centroid is not (a bay's bend)."""
    try:
        geometry = load_area(area).geometry
    except (OSError, ValueError, KeyError, TypeError, AttributeError, IndexError) as exc:
        detail = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise ScenarioError(f"AREA {area}: not a GeoJSON area: {detail}") from None
    point = geometry.centroid
    if not geometry.contains(point):
        point = geometry.representative_point()
    return round(float(point.y), 7), round(float(point.x), 7)  # 1 cm


def _relative(path: Path, folder: Path) -> str:
    try:
        return Path(os.path.relpath(path.resolve(), folder)).as_posix()
    except ValueError:  # another drive
        return path.resolve().as_posix()


def _as_flag(message: str, out: Path) -> str:
    """The reader's "FILE: fleet.count: 0 is outside ..." as "--count: 0 is outside ..."."""
    field, sep, what = message.removeprefix(f"{out}: ").partition(": ")
    for pattern, flag in _FLAGS:
        if sep and re.fullmatch(pattern, field):
            return f"{flag}: {what}"
    return message


def _render(data: dict[str, Any], schema: str) -> str:
    lines = [f"{SCHEMA_DIRECTIVE} {schema}", "",
             "# Written by `vil scenario new`. Every field not here takes its default: the schema above",
             "# lists them all (an editor reading it completes and checks them); vil scenario check FILE.",]
    for table, fields in data.items():
        for entry in fields if isinstance(fields, list) else [fields]:
            lines += ["", f"[[{table}]]" if isinstance(fields, list) else f"[{table}]"]
            lines += [f"{key} = {_toml(value)}" for key, value in entry.items()]
    return "\n".join(lines) + "\n"


def _toml(value: Any) -> str:
    if isinstance(value, list):
        return f"[{', '.join(map(_toml, value))}]"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)  # a JSON string is a TOML basic string
    return repr(value) if isinstance(value, float) else str(value)
