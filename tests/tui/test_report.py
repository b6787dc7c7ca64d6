"""`vil report`: figures, a page that reads on its own, RFC 7946 GeoJSON, and runs compared.

The runs are real: the live-console recording (pool12, 240 s, no result.json: indices from the
replay), a headless pool12 run with no collection that runs aMussels flat, and a two-aPad run
with one aPad lost (re-shares).
"""

from __future__ import annotations

import json
import shutil
from dataclasses import replace
from datetime import datetime
from html.parser import HTMLParser
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

import numpy as np
import pytest
from shapely.geometry import LinearRing

from gcs.cli.main import main
from gcs.loop.energy_sharing import LoopControl
from gcs.mission.headless import run_mission
from gcs.mission.world import MISSION_TELEMETRY_HZ, LinkOptions, headless_world
from gcs.report.load import load_run
from gcs.scenario.reader import load_scenario

pytestmark = pytest.mark.tui

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
SINGLE_FIGURES = ("uptime.png", "active.png", "battery.png", "battery_map.png", "states.png", "track.png")


class Links(HTMLParser):
    """Every src and href of a page, and the text of its table headers."""

    def __init__(self) -> None:
        super().__init__()
        self.urls: list[str] = []
        self.headers: list[str] = []
        self._in_th = False

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self.urls += [v for k, v in attrs if k in ("src", "href") and v is not None]
        self._in_th = tag == "th"

    def handle_data(self, data: str) -> None:
        if self._in_th:
            self.headers.append(data)
            self._in_th = False


def links(page: Path) -> Links:
    parser = Links()
    parser.feed(page.read_text(encoding="utf-8"))
    return parser


def assert_local_page(page: Path) -> None:
    """Every asset of the page is a file beside it: no scheme, no host, and the file is there."""
    for url in links(page).urls:
        parts = urlsplit(url)
        assert not parts.scheme and not parts.netloc, url
        if parts.path:
            assert (page.parent / parts.path).is_file(), url


@pytest.fixture(scope="module")
def single(recorded_run: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The console recording's report, written where `vil report RUN` puts it by default."""
    run = tmp_path_factory.mktemp("single") / "pool12-console"
    run.mkdir()
    for name in ("gcs.tlog", "events.jsonl", "console.json"):
        shutil.copy(recorded_run / name, run / name)
    assert main(["report", str(run)]) == 0
    return run / "report"


@pytest.fixture(scope="module")
def compared(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A pool12 run with no collection (aMussels run flat) beside a pool12x2 run that loses aPad 2."""
    root = tmp_path_factory.mktemp("compare")
    flat = root / "pool12-none"
    run_mission(load_scenario("pool12").with_overrides(strategy="none", duration_s=360.0, theta=120.0), flat)
    swarm = root / "pool12x2"
    run_mission(load_scenario("pool12x2").with_overrides(duration_s=420.0), swarm,
                options=LinkOptions(fail_apads=((2, 200.0),)))
    out = root / "report"
    assert main(["report", str(flat), str(swarm), "-o", str(out)]) == 0
    return out


def test_one_run_writes_figures_a_self_contained_page_and_geojson(single: Path) -> None:
    for name in SINGLE_FIGURES:
        data = (single / name).read_bytes()
        assert data.startswith(PNG_MAGIC) and len(data) > 20_000, name
    assert not (single / "partition.png").exists()  # one aPad: no sharing to draw
    page = single / "index.html"
    text = page.read_text(encoding="utf-8")
    headers = links(page).headers
    for header in ("avg uptime %", "cost m", "active aMussels (mean)", "dockings", "state at the end", "event"):
        assert header in headers, header
    assert "Indices from replay" in text  # no result.json: the figures come from the log itself
    assert "aPad 1 home, 43.940000° N 15.439838° E" in text  # the maps' origin, stated
    assert "never collected" in text  # 4 of 12 docked in 240 s: the others are flagged
    assert text.count("<img ") == len(SINGLE_FIGURES)
    assert "docked" in text and "call up" in text  # the event timeline
    assert_local_page(page)


def test_geojson_is_rfc7946_with_area_timed_track_and_a_point_per_amussel(single: Path) -> None:
    geo = json.loads((single / "run.geojson").read_text(), parse_constant=lambda c: pytest.fail(f"{c} in JSON"))
    assert geo["type"] == "FeatureCollection"
    kinds = [f["properties"]["kind"] for f in geo["features"]]
    assert kinds == ["area", "apad_track"] + ["amussel"] * 12
    area = geo["features"][0]["geometry"]
    assert area["type"] == "Polygon"
    ring = area["coordinates"][0]
    assert ring[0] == ring[-1] and LinearRing(ring).is_ccw  # closed; exterior counterclockwise (§3.1.6)
    track = geo["features"][1]
    coords, times = track["geometry"]["coordinates"], track["properties"]["times"]
    assert track["geometry"]["type"] == "LineString" and len(coords) > 200
    assert len(times) == len(coords) == len(track["properties"]["mission_times_s"])
    assert all(15.43 < lon < 15.45 and 43.93 < lat < 43.95 for lon, lat in coords)  # [lon, lat]
    stamps = [datetime.fromisoformat(t) for t in times]
    assert stamps == sorted(stamps) and stamps[0].tzinfo is not None
    points = geo["features"][2:]
    assert sorted(p["properties"]["amussel_id"] for p in points) == list(range(1, 13))
    for p in points:
        lon, lat = p["geometry"]["coordinates"]
        assert p["geometry"]["type"] == "Point" and 15.43 < lon < 15.45 and 43.93 < lat < 43.95
        assert {"uptime_pct", "dockings", "never_collected", "depleted_s", "state_s"} <= set(p["properties"])
    docked = {p["properties"]["amussel_id"] for p in points if p["properties"]["dockings"]}
    assert docked == {3, 6, 8, 11}  # the first collection round, as the events say


def test_several_runs_are_compared_each_with_its_own_report(compared: Path) -> None:
    for name in ("compare_active.png", "compare_cost.png", "compare_uptime.png"):
        assert (compared / name).read_bytes().startswith(PNG_MAGIC), name
    page = compared / "index.html"
    text = page.read_text(encoding="utf-8")
    assert "Comparison of 2 runs" in text and "pool12 none seed 1" in text and "pool12x2 cautious seed 1" in text
    assert_local_page(page)
    assert {"pool12-none/index.html", "pool12x2/index.html"} <= set(links(page).urls)
    swarm = compared / "pool12x2"
    assert (swarm / "partition.png").read_bytes().startswith(PNG_MAGIC)
    geo = json.loads((swarm / "run.geojson").read_text())
    tracks = [f for f in geo["features"] if f["properties"]["kind"] == "apad_track"]
    assert [t["properties"]["apad"] for t in tracks] == [1, 2]
    assert all(len(t["properties"]["times"]) == len(t["geometry"]["coordinates"]) for t in tracks)


def test_depleted_and_never_collected_amussels_are_marked(compared: Path) -> None:
    flat = compared / "pool12-none"
    text = (flat / "index.html").read_text(encoding="utf-8")
    assert "Indices from result.json" in text and "paper (Table II)" in text
    points = [f["properties"] for f in json.loads((flat / "run.geojson").read_text())["features"]
              if f["properties"]["kind"] == "amussel"]
    assert all(p["never_collected"] for p in points)  # strategy none collects nobody
    depleted = [p["amussel_id"] for p in points if p["depleted_s"] > 0]
    assert depleted and all(p["end_state"] == "depleted" for p in points if p["amussel_id"] in depleted)
    assert all(0 < p["first_depleted_s"] < 360 for p in points if p["amussel_id"] in depleted)
    assert all(p["first_depleted_s"] is None for p in points if p["amussel_id"] not in depleted)
    assert all(sum(p["state_s"].values()) == pytest.approx(360, abs=2) for p in points)  # the whole mission
    assert f'<tr class="flag"><td class="text">{depleted[0]}</td>' in text
    assert "never collected, depleted" in text


def test_bad_input_is_one_line(recorded_run: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["report", str(tmp_path / "nope"), "-o", str(tmp_path / "out")]) == 2
    assert capsys.readouterr().err.startswith("vil report:")
    assert main(["report", str(recorded_run), str(recorded_run)]) == 2  # several runs, no -o
    err = capsys.readouterr().err
    assert err.startswith("vil report:") and "-o" in err and err.count("\n") == 1
    run = tmp_path / "run"
    run.mkdir()
    shutil.copy(recorded_run / "gcs.tlog", run / "gcs.tlog")
    (run / "result.json").write_text('{"mussels": [{"id": 1, "uptime_pct": "high"}]}')
    assert main(["report", str(run), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err == f"vil report: {run / 'result.json'}: mussels[0].uptime_pct is 'high', not a number\n"
    assert not (tmp_path / "out").exists()


def test_a_strategy_switch_and_a_docking_the_loop_did_not_list_are_reported(tmp_path: Path) -> None:
    """Issue 23: a console session read "strategy -" (it was cautious, then weighted) and an aMussel
    "docked" yet "never collected, 0 dockings" (docked by the operator, so not in the loop's list)."""
    run = tmp_path / "switched"
    world = headless_world(load_scenario("pool12"), run)
    control = LoopControl()
    try:
        world.clock.scheduler.every(60.0, lambda now_us: setattr(control, "strategy", "weighted"), "switch", 60_000_000)
        world.clock.scheduler.every(470.0, lambda now_us: setattr(control, "stop", True), "stop", 470_000_000)
        world.api.wait_apad(timeout_s=10.0)
        world.api.set_telemetry_rates(MISSION_TELEMETRY_HZ)
        world.mission_loop(control).run()
    finally:
        world.close()
    data = load_run(run, "pool12")
    docked_at_end = [m for m in data.mussels if m.end_state == "docked"]
    assert docked_at_end  # weighted (from 420 s) docked some by 470 s
    (run / "result.json").write_text(json.dumps(  # a result whose lists name no docking at all
        {"scenario": "pool12", "strategy": "cautious", "seed": 1,
         "mussels": [{"id": int(i), "dockings": []} for i in data.ids]}))
    data = load_run(run, "pool12")
    assert data.strategy == "cautious, then weighted" and data.title == "pool12 cautious, then weighted seed 1"
    for m in data.mussels:
        assert (m.end_state == "docked") <= (m.dockings >= 1 and not m.never_collected), m


def _days(n: int, apads: tuple[str, ...]) -> list[dict[str, object]]:
    """Day rows as gcs.results.days writes them into result.json, with figures that differ day by day."""
    return [{"day": d, "from_s": 48.0 * (d - 1), "to_s": 48.0 * d, "uptime_pct": 40.0 + (d % 9) * 5.0,
             "alive": 12 - d // 10, "depleted": int(d % 10 == 0),
             "charges": {a: (d % 7) + int(a) for a in apads},
             "passed_wh": {a: 2.5 * (d % 5) + int(a) for a in apads}} for d in range(1, n + 1)]


def _legends_off_the_data(fig: Any) -> int:
    """How many legends the figure has, each checked to lie outside every plot it could cover."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    legends = [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
    for legend in legends:
        box = legend.get_window_extent(renderer)
        for ax in fig.axes:
            plot = ax.get_window_extent(renderer)
            assert box.y0 >= plot.y1 - 1 or box.y1 <= plot.y0 + 1 or box.x0 >= plot.x1 or box.x1 <= plot.x0, \
                [t.get_text() for t in legend.get_texts()]
    return len(legends)


def test_a_long_run_is_drawn_by_week_its_legend_off_the_data(compared: Path, tmp_path: Path) -> None:
    """Issue 39: 210 simulated days of five aPads were ten lines under a legend. Past LONG_DAYS: the
    fleet's uptime as a weekly band, each aPad's charges and Wh a day (the week's mean) as heat maps."""
    from matplotlib.collections import QuadMesh

    from gcs.report.per_day import days_figure, days_png
    from gcs.report.per_week import LONG_DAYS

    swarm = load_run(compared.parent / "pool12x2")
    rows = _days(45, ("1", "2"))
    assert len(rows) > LONG_DAYS
    data = replace(swarm, result={**swarm.result, "days": rows})
    fig = days_figure(data)
    assert fig is not None and fig.get_suptitle().startswith("Per simulated week, 45 days")
    meshes = [c for ax in fig.axes for c in ax.collections if isinstance(c, QuadMesh) and c.colorbar]
    assert len(meshes) == 2  # charged, then Wh passed: aPad x week
    weeks = [rows[k:k + 7] for k in range(0, 45, 7)]  # 6 weeks of 7, then 3 days
    for mesh, key in zip(meshes, ("charges", "passed_wh"), strict=True):
        shown = np.asarray(mesh.get_array()).reshape(2, len(weeks))
        expected = [[np.mean([r[key][a] for r in week]) for week in weeks] for a in ("1", "2")]
        np.testing.assert_allclose(shown, expected)
    lines = [line for ax in fig.axes for line in ax.get_lines() if len(line.get_xdata()) == 45]
    assert [line.get_label() for line in lines] == ["aMussels alive at the day's end"]  # no line per aPad a day
    assert _legends_off_the_data(fig) == 1
    assert days_png(data, tmp_path / "days.png") is not None
    assert (tmp_path / "days.png").read_bytes().startswith(PNG_MAGIC)


def test_a_short_run_keeps_a_line_a_day_its_legends_off_the_data(compared: Path) -> None:
    from gcs.report.per_day import days_figure

    swarm = load_run(compared.parent / "pool12x2")
    fig = days_figure(replace(swarm, result={**swarm.result, "days": _days(12, ("1", "2"))}))
    assert fig is not None
    lines = [line for ax in fig.axes for line in ax.get_lines() if len(line.get_xdata()) == 12]
    assert len(lines) == 1 + 2 * 2  # alive; each aPad's charged and Wh passed, day by day as before
    assert _legends_off_the_data(fig) == 2
