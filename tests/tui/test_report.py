"""`vil report`: PNGs, the HTML page with the Table II indices, GeoJSON, from a recorded run."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from gcs.cli import main

pytestmark = pytest.mark.tui

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def test_report_writes_plots_page_and_geojson(recorded_run: Path, tmp_path: Path) -> None:
    out = tmp_path / "report"
    assert main(["report", str(recorded_run), "-o", str(out)]) == 0
    for name in ("battery.png", "active.png", "uptime.png", "track.png"):
        data = (out / name).read_bytes()
        assert data.startswith(PNG_MAGIC) and len(data) > 20_000, name
    page = (out / "index.html").read_text()
    for text in ("avg uptime %", "cost m", "active aMussels (mean)", "33.4", "battery.png", "run.geojson"):
        assert text in page
    geo = json.loads((out / "run.geojson").read_text())
    kinds = [f["geometry"]["type"] for f in geo["features"]]
    assert kinds[0] == "LineString" and kinds.count("Point") == 24  # 12 aMussels, start and end
    track = geo["features"][0]["geometry"]["coordinates"]
    assert len(track) > 200 and all(15.43 < lon < 15.45 and 43.93 < lat < 43.95 for lon, lat in track)


def test_report_of_a_missing_run_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["report", str(tmp_path / "nope"), "-o", str(tmp_path / "out")]) == 2
    assert capsys.readouterr().err.startswith("vil report:")


def test_report_takes_the_indices_from_result_json(recorded_run: Path, tmp_path: Path) -> None:
    run = tmp_path / "run"
    run.mkdir()
    for name in ("gcs.tlog", "events.jsonl", "console.json"):
        (run / name).write_bytes((recorded_run / name).read_bytes())
    result = {"scenario": "pool12", "strategy": "cautious", "seed": 1, "uptime": {"avg": 70.5, "max": 90.0,
              "min": 50.25}, "cost_m": 123.4, "active_avg": 8.5, "end_reason": "mission time"}
    (run / "result.json").write_text(json.dumps(result))
    out = tmp_path / "report"
    assert main(["report", str(run), "-o", str(out)]) == 0
    page = (out / "index.html").read_text()
    assert "pool12 cautious seed 1" in page and "<td>70.50</td>" in page and "<td>123.4</td>" in page
    assert "paper (Table II)" in page and "<td>74.37</td>" in page  # the paper's row beside ours


def test_a_swarm_run_report_draws_the_partition_and_a_single_run_does_not(
        recorded_run: Path, tmp_path: Path) -> None:
    from gcs.mission.headless import run_mission
    from gcs.mission.scenario import load_scenario
    from gcs.mission.world import LinkOptions

    run = tmp_path / "run"
    run_mission(load_scenario("pool12x2").with_overrides(duration_s=420.0), run,
                options=LinkOptions(fail_apads=((2, 200.0),)))
    out = tmp_path / "report"
    assert main(["report", str(run), "-o", str(out)]) == 0
    data = (out / "partition.png").read_bytes()
    assert data.startswith(PNG_MAGIC) and len(data) > 20_000
    assert 'src="partition.png"' in (out / "index.html").read_text()
    single = tmp_path / "single"
    assert main(["report", str(recorded_run), "-o", str(single)]) == 0
    assert not (single / "partition.png").exists() and "partition.png" not in (single / "index.html").read_text()
