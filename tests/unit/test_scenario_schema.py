"""The scenario schema is the reader's (issue 22): shipped as generated, every shipped scenario valid and
naming it, a misspelt field refused by name, and the schema refusing what the reader refuses where a
schema can say so; `vil scenario check` and `new` in one line each (in process: no interpreter start)."""

from __future__ import annotations

import json
import os
import tomllib
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gcs.cli.main import main
from gcs.scenario.reader import ScenarioError, load_scenario, scenario_from_data
from gcs.scenario.schema import SCHEMA_PATH, schema_problems, schema_text

ROOT = Path(__file__).resolve().parents[2]
MISSIONS = ROOT / "missions"
SHIPPED = sorted(MISSIONS.glob("*.toml"))
POOL12 = MISSIONS / "pool12.toml"
SCHEMA = json.loads(SCHEMA_PATH.read_text())
# What a JSON Schema cannot say, so the reader alone refuses: files that do not exist, durations of zero
# or over 90 days, start_battery's min > max, latitudes beyond +-90, strategies (plugins: any string).
READER_ONLY = {"fleet.area", "fleet.start_config", "mission.duration", "fleet.start_battery", "apad.home",
               "mission.collect_strategy"}


def test_the_shipped_schema_is_what_the_reader_makes_today() -> None:
    assert SCHEMA_PATH.read_text() == schema_text(), (
        "the scenario reader changed: regenerate with python -m gcs.scenario.schema --write")


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.stem)
def test_every_shipped_scenario_is_valid_and_names_the_schema_on_its_first_line(path: Path) -> None:
    assert schema_problems(tomllib.loads(path.read_text())) == []
    directive = path.read_text().splitlines()[0]
    assert directive.startswith("#:schema ")
    assert (path.parent / directive.split(" ", 1)[1]).resolve() == SCHEMA_PATH


def test_the_schema_holds_each_field_with_its_range_default_and_required() -> None:
    fleet, mission = SCHEMA["properties"]["fleet"], SCHEMA["properties"]["mission"]
    assert fleet["properties"]["count"] | {"description": ""} == {
        "description": "", "type": "integer", "minimum": 1, "maximum": 65535}
    assert fleet["required"] == ["count", "area"] and SCHEMA["required"] == ["fleet", "apad"]
    assert mission["properties"]["theta"]["default"] == 30.0
    assert "enum" not in mission["properties"]["collect_strategy"]  # plugins: any name or file:function
    assert mission["properties"]["redeploy_strategy"]["enum"] == ["greedy"]
    tables = [SCHEMA, SCHEMA["definitions"]["apad"], *SCHEMA["properties"].values()]
    assert all(t["additionalProperties"] is False for t in tables if t.get("type") == "object")


def _pool12() -> dict[str, Any]:
    return tomllib.loads(POOL12.read_text())


def test_a_misspelt_field_is_refused_by_the_schema_by_its_name() -> None:
    data = _pool12()
    data["fleet"]["cuont"] = data["fleet"].pop("count")
    assert schema_problems(data) == ["fleet.cuont: unknown field (did you mean fleet.count?)", "fleet.count: missing"]
    data = _pool12()
    data["apad"] = [data["apad"], {"home": [43.94, 15.44], "speeed_mps": 1.0}]
    assert schema_problems(data) == ["apad[1].speeed_mps: unknown field (did you mean apad[1].speed_mps?)"]


def _fields() -> list[tuple[str, str, dict[str, Any]]]:
    """Every (table, field, its schema) of the format."""
    tables = {k: v for k, v in SCHEMA["properties"].items() if "properties" in v}
    tables["apad"] = SCHEMA["definitions"]["apad"]
    return [(t, k, s) for t, table in tables.items() for k, s in table["properties"].items()]


def _edges(schema: dict[str, Any]) -> list[Any]:
    """Values at and just beyond a field's limits."""
    limits = schema.get("items", schema)
    out: list[Any] = list(schema.get("enum", []))
    for bound, step in (("minimum", -1), ("maximum", 1)):
        if bound in limits:
            edge = limits[bound]
            out += [edge, edge + step, edge + step * 1e-3] if schema["type"] != "array" else [[edge, edge + step]]
    return out


_ANY = st.one_of(st.integers(-10**6, 10**6), st.floats(-1e6, 1e6, allow_nan=False), st.booleans(),
                 st.text(max_size=4), st.sampled_from(["40m", "0s", "1.5h", "x.toml"]),
                 st.lists(st.one_of(st.integers(-200, 200), st.floats(-200, 200)), max_size=3))


def _reader_refuses(data: dict[str, Any]) -> bool:
    try:
        scenario_from_data(POOL12, data)
    except ScenarioError:
        return True
    return False


def _disagreement(table: str, key: str, value: Any) -> str | None:
    """Where the schema refuses what the reader takes (never allowed), or takes what the reader refuses
    (allowed only for what a schema cannot say): the field and value, else None."""
    data = _pool12()
    data.setdefault(table, {})[key] = value  # a table pool12 leaves out ([acoustic]) too
    by_schema, by_reader = bool(schema_problems(data)), _reader_refuses(data)
    if by_schema == by_reader or (by_reader and f"{table}.{key}" in READER_ONLY):
        return None
    return f"{table}.{key} = {value!r}: the schema {'refuses' if by_schema else 'takes'} it, the reader does not"


def test_the_schema_and_the_reader_agree_at_every_limit_of_every_field() -> None:
    cases = [(t, k, v) for t, k, s in _fields() for v in _edges(s)]
    assert len(cases) > 80
    assert [d for d in (_disagreement(*c) for c in cases) if d] == []


@settings(max_examples=200, deadline=None)
@given(st.sampled_from([f for f in _fields() if f[1] != "collect_strategy"]), _ANY)  # "re:x" would import re
def test_the_schema_and_the_reader_agree_on_any_value(field: tuple[str, str, dict[str, Any]], value: Any) -> None:
    assert _disagreement(field[0], field[1], value) is None


@pytest.mark.parametrize("table", ["scenario", "mission", "fleet", "environment", "apad", "acoustic"])
def test_an_unknown_field_in_any_table_is_refused_by_both(table: str) -> None:
    data = _pool12()
    data.setdefault(table, {})["typo"] = 1
    assert schema_problems(data) == [f"{table}.typo: unknown field"] and _reader_refuses(data)


def test_check_names_a_misspelt_field_in_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text(POOL12.read_text().replace("count = 12", "cuont = 12").replace('"areas/', f'"{MISSIONS}/areas/')
                   .replace('"starts/', f'"{MISSIONS}/starts/'))
    assert main(["scenario", "check", str(bad)]) == 2
    out = capsys.readouterr()
    assert out.err.splitlines() == [f"{bad}: fleet.cuont: unknown field (did you mean fleet.count?)",
                                    f"{bad}: fleet.count: missing"]
    assert main(["scenario", "check", "pool12", str(bad)]) == 2  # every file is checked; the worst status
    assert capsys.readouterr().out.splitlines() == [f"{POOL12}: ok: pool12, 12 aMussels, 1 aPad, 40 min"]


def test_check_warns_when_a_copys_schema_line_points_nowhere(tmp_path: Path,
                                                           capsys: pytest.CaptureFixture[str]) -> None:
    """`cp missions/pool12.toml mine.toml`: the copy runs, but its `#:schema ../gcs/...` leads an editor nowhere;
    check says ok and warns in one line with the line to write. Fixed, or pointing at the schema, no warning."""
    text = POOL12.read_text().replace('"areas/', f'"{MISSIONS}/areas/').replace('"starts/', f'"{MISSIONS}/starts/')
    mine = tmp_path / "mine.toml"
    mine.write_text(text)
    assert main(["scenario", "check", str(mine)]) == 0
    out = capsys.readouterr()
    assert out.out.splitlines() == [f"{mine}: ok: mine, 12 aMussels, 1 aPad, 40 min"]
    (warning,) = out.err.splitlines()
    fix = f"#:schema {Path(os.path.relpath(SCHEMA_PATH, tmp_path.resolve()))}"
    assert warning == (f"{mine}: warning: #:schema ../gcs/scenario/scenario.schema.json points nowhere from this "
                       f"file's folder; editors find the schema with {fix}")
    mine.write_text(text.replace("#:schema ../gcs/scenario/scenario.schema.json", fix))
    assert main(["scenario", "check", str(mine)]) == 0 and capsys.readouterr().err == ""
    (tmp_path / "old.schema.json").write_text("{}")
    mine.write_text(text.replace("../gcs/scenario/scenario.schema.json", "old.schema.json"))
    assert main(["scenario", "check", str(mine)]) == 0
    assert "#:schema old.schema.json is not the shipped schema" in capsys.readouterr().err
    mine.write_text(text.replace("#:schema ../gcs/scenario/scenario.schema.json", "# mine"))
    assert main(["scenario", "check", str(mine), "pool12"]) == 0 and capsys.readouterr().err == ""  # none: no word


def test_check_runs_the_reader_for_what_the_schema_cannot_say(tmp_path: Path,
                                                              capsys: pytest.CaptureFixture[str]) -> None:
    copied = tmp_path / "copied.toml"
    copied.write_text(POOL12.read_text())  # its paths do not follow it
    assert main(["scenario", "check", str(copied)]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert line.startswith(f"{copied}: fleet.area: no such file")


def test_new_writes_a_file_the_reader_and_check_accept(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "sub" / "two.toml"
    out.parent.mkdir()
    area = MISSIONS / "areas" / "pool.geojson"
    args = ["scenario", "new", str(area), "--count", "5", "--apad", "43.94,15.4399", "--apad", "43.94,15.4401",
            "-o", str(out)]
    assert main(args) == 0
    text = out.read_text()
    assert text.startswith("#:schema ../") and 'area = "../' in text  # relative to its folder, not absolute
    scenario = load_scenario(out)
    assert (scenario.name, scenario.fleet.count, scenario.fleet.area) == ("two", 5, area)
    assert [(a.system_id, a.home_lat_deg) for a in scenario.apads] == [(1, 43.94), (2, 43.94)]
    assert main(["scenario", "check", str(out)]) == 0
    assert main(args) == 2 and out.read_text() == text  # kept without --force
    assert capsys.readouterr().err == f"vil scenario new: {out} exists (--force overwrites it)\n"
    assert main([*args[:-4], "-o", str(out), "--force"]) == 0  # one aPad: in the area's middle
    assert load_scenario(out).apad.home_lat_deg == pytest.approx(43.94)


@pytest.mark.parametrize(
    "change, message",
    [
        ({"AREA": "no_such_area.geojson"}, "AREA no_such_area.geojson: no such file"),
        ({"--count": "0"}, "--count: 0 is less than the minimum of 1"),
        ({"--apad": "95,15.44"}, "--apad: [95.0, 15.44] is not [lat, lon] in degrees"),
        ({"--apad": "43.94"}, "argument --apad: expected LAT,LON in degrees"),
        ({"AREA": str(POOL12)}, "not a GeoJSON area"),
    ],
)
def test_new_refuses_bad_input_in_one_line_and_writes_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], change: dict[str, str], message: str
) -> None:
    given_ = {"AREA": str(MISSIONS / "areas" / "pool.geojson"), "--count": "12"} | change
    argv = ["scenario", "new", given_.pop("AREA"), *[s for kv in given_.items() for s in kv], "-o",
            str(tmp_path / "x.toml")]
    assert _status(argv) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1, err
    assert list(tmp_path.iterdir()) == []


def _status(argv: list[str]) -> int:
    """`vil`'s exit status, from a flag argparse refuses too."""
    try:
        return main(argv)
    except SystemExit as exc:
        return int(str(exc.code))
