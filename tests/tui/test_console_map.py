"""The map, driven headless with Pilot on one still frame of pool12: 12 aMussels where the start
configuration puts them, the aPad in the pool with aMussels 4 and 7 docked in its
slots 1 and 3 (a docked aMussel reports the aPad's own position, as on the link).

What an operator reads off the map: the slots beside the aPad, the selected aMussel highlighted
with its id, the id under the mouse, a click picks an aMussel, a scale bar and a lat/lon grid
whose labels are where pyproj puts those parallels and meridians.
"""

from __future__ import annotations

import asyncio
import re
from pathlib import Path

import numpy as np
import pytest
from rich.style import Style
from tui_helpers import screen_text, wait_for

from apad_sitl.vocabulary import Latch
from gcs.console.app import ConsoleApp
from gcs.link.registry import VehicleRegistry
from gcs.link.telemetry import DEG_E7, Heartbeat, MusselView, Position, SlotView
from gcs.scenario.reader import load_scenario
from gcs.view.model import MissionView, area_outline
from gcs.view.snapshot import Snapshot
from mussel_sim.geo import LocalFrame
from mussel_sim.placement import load_area
from mussel_sim.startconfig import generate_start_config
from mussel_sim.vocabulary import MusselState

pytestmark = pytest.mark.tui

POOL12 = Path(__file__).resolve().parents[2] / "missions" / "pool12.toml"
DOCKED = {1: 4, 3: 7}  # slot -> aMussel


def pool12_frame() -> Snapshot:
    scenario = load_scenario(POOL12)
    area = load_area(scenario.fleet.area)
    config = generate_start_config(area, 12, area.frame(), np.random.default_rng(1))
    registry = VehicleRegistry()
    model = MissionView(registry, 1, 0.8, 2400.0, "test", config.ids.astype(np.int64), area_outline(area.geometry))
    lon_lo, lat_lo, lon_hi, lat_hi = area.geometry.bounds
    apad_lat, apad_lon = lat_lo + 0.2 * (lat_hi - lat_lo), lon_lo + 0.2 * (lon_hi - lon_lo)  # clear of the fleet
    registry.apply(1, Heartbeat(4, True), 0)
    registry.apply(1, Position(apad_lat, apad_lon, 0.0), 0)
    for slot, mussel in DOCKED.items():
        registry.apply(1, SlotView(slot, mussel, Latch.LATCHED, True), 0)
    for i, mussel in enumerate(config.ids.tolist()):
        docked = mussel in DOCKED.values()
        lat, lon = (apad_lat, apad_lon) if docked else (config.lat_deg[i], config.lon_deg[i])
        registry.apply(250, MusselView(mussel, round(lat * DEG_E7), round(lon * DEG_E7), 3.0, 0.5 + 0.04 * i, 4000,
                                       MusselState.DOCKED if docked else MusselState.ACTIVE, True, 0), 0)
    model.sample(0.0)
    return model.snapshot(60.0)


class StillConsole(ConsoleApp):
    """The console's screen showing one frame."""

    def __init__(self, frame: Snapshot) -> None:
        super().__init__()
        self.frame = frame

    def current(self) -> Snapshot | None:
        return self.frame


def map_rows(app: StillConsole) -> list[str]:
    region = app.map_view.content_region
    rows = screen_text(app).split("\n")[region.y: region.bottom]
    return [row[region.x: region.right] for row in rows]


def styled_cells(app: StillConsole, text: str) -> list[Style]:
    """The styles of the map's segments holding `text`."""
    region = app.map_view.content_region
    strips = app.screen._compositor.render_strips()[region.y: region.bottom]
    return [seg.style for strip in strips for seg in strip if text in seg.text and seg.style is not None]


def test_slots_selection_hover_click_scale_and_grid() -> None:
    frame = pool12_frame()

    async def scenario() -> None:
        app = StillConsole(frame)
        async with app.run_test(size=(150, 46)) as pilot:
            await wait_for(pilot, lambda: "◆" in screen_text(app) and app.fleet.row_count == 12)
            rows = map_rows(app)
            # The docked aMussels sit in the aPad's slots, ● full and ○ empty, not under the aPad.
            (slot_row,) = [r for r in rows if "◆●○●○" in r]
            assert rows.index(slot_row) == int(app.map_view.hits.cy[app.map_view.hits.ids == 7][0])
            assert sum(r.count("●") for r in rows) == 12  # ten in the pool, two in the slots

            # The table's selection is highlighted on the map with its id: a docked one after the slots.
            app.fleet.select_mussel(7)
            await wait_for(pilot, lambda: any("◆●○●○7" in r for r in map_rows(app)))
            assert any(s.reverse for s in styled_cells(app, "●")), "the selected aMussel's marker stands out"
            app.fleet.select_mussel(2)
            await wait_for(pilot, lambda: any("●2" in r for r in map_rows(app)))
            assert not any("◆●○●○7" in r for r in map_rows(app))

            # The mouse over an aMussel shows its id; a click selects it in the fleet table.
            hits = app.map_view.hits
            k = int(np.flatnonzero(hits.ids == 9)[0])
            offset = (int(hits.cx[k]) + 1, int(hits.cy[k]) + 1)  # + the border
            await pilot.hover("#map", offset=offset)
            await wait_for(pilot, lambda: "●9" in map_rows(app)[int(hits.cy[k])])
            await pilot.click("#map", offset=offset)
            await wait_for(pilot, lambda: app.fleet.selected_mussel() == 9)

            # A scale bar of a round length, and grid labels where pyproj puts the lines.
            rows = map_rows(app)
            bar = re.search(r"(\d+(?:\.\d+)?) m", rows[-1])
            assert bar is not None and float(bar.group(1)) in {1, 2, 5, 10, 20, 50}
            bar_cells = rows[-1].index(bar.group(0)) - 1  # the bar runs from the left edge to its label
            view = app.map_view._view
            assert view is not None
            assert abs(bar_cells * 2 * view.m - float(bar.group(1))) <= 4 * view.m  # within two columns
            frame_ = LocalFrame(view.frame.origin_lat_deg, view.frame.origin_lon_deg)
            for y, row in enumerate(rows):
                if m := re.match(r"(\d+\.\d+)°N", row):
                    _, north_m = frame_.to_local(float(m.group(1)), view.frame.origin_lon_deg)
                    _, dot_y = view.dots(np.zeros(1), np.array([north_m]))
                    assert int(dot_y[0] // 4) == y  # the label sits on its parallel's row
            assert any(re.match(r"\d+\.\d+°N", r) for r in rows)
            assert re.search(r"\d+\.\d+°E", rows[0])

    asyncio.run(scenario())
