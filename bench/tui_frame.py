"""Time to render one console frame with 12, 200 and 1,000 aMussels.

    .venv/bin/python bench/tui_frame.py

The fleet is the real model (mussel_sim) drawn in the bay area and stepped for 10 simulated
minutes; its statuses go into the console model as AMUSSEL_STATUS messages, as on the link.
A frame = the app taking a new snapshot and Textual compositing the whole 160x48 screen
(map, table, status, three plots), headless. The budget at 10 fps is 100 ms.
"""

from __future__ import annotations

import asyncio
import statistics
import time
from pathlib import Path

import numpy as np

from gcs.console.app import ConsoleApp
from gcs.console.model import ConsoleModel, Snapshot, area_outline
from mavlink_dialect import mavlink
from mussel_sim.fleet import step
from mussel_sim.fleet_state import FleetInputs, FleetParams, initial_state
from mussel_sim.placement import load_area
from mussel_sim.startconfig import generate_start_config

BAY = Path(__file__).resolve().parents[1] / "missions" / "areas" / "bay.geojson"
SIZE = (160, 48)
FRAMES = 30


def snapshots(n: int, count: int) -> list[Snapshot]:
    """`count` successive 1 Hz snapshots of an n-aMussel fleet, after a 600 s history."""
    area = load_area(BAY)
    frame = area.frame()
    rng = np.random.default_rng(1)
    config = generate_start_config(area, n, frame, rng)
    params = FleetParams()
    state = initial_state(config, frame, params)
    model = ConsoleModel(1, 0.8, 2400.0, "bench", config.ids.astype(np.int64), area_outline(area.geometry))
    out = []
    for k in range(600 + count):
        state, _ = step(state, FleetInputs.make(), params, rng, 1.0)
        lat, lon = frame.to_geodetic(state.x_m, state.y_m)
        for i in range(n):
            model.handle(mavlink.MAVLink_amussel_status_message(
                state.time_us, int(state.ids[i]), round(lat[i] * 1e7), round(lon[i] * 1e7), 3.0,
                float(state.battery_frac[i]), 4000, int(state.state[i]), 1))
        model.sample(k)
        if k >= 600:
            out.append(model.snapshot(float(k)))
    return out


class BenchApp(ConsoleApp):
    def __init__(self, frames: list[Snapshot]) -> None:
        super().__init__()
        self.frames = frames
        self.index = 0

    def current(self) -> Snapshot | None:
        return self.frames[self.index]

    def on_mount(self) -> None:
        super().on_mount()
        self.map_view.border_title = "bench"


async def frame_times(frames: list[Snapshot]) -> list[float]:
    app = BenchApp(frames)
    times = []
    async with app.run_test(size=SIZE) as pilot:
        await pilot.pause(0.2)
        for i in range(1, len(frames)):
            app.index = i
            t0 = time.perf_counter()
            app.redraw()
            # Composite every widget to strips, as a refresh to the terminal does.
            app.screen._compositor.render_strips()
            times.append(time.perf_counter() - t0)
            await pilot.pause()
    return times


def main() -> None:
    print(f"console frame, {SIZE[0]}x{SIZE[1]} cells, median of {FRAMES - 1} frames (budget 100 ms at 10 fps)")
    for n in (12, 200, 1000):
        frames = snapshots(n, FRAMES)
        times = asyncio.run(frame_times(frames))
        print(f"{n:>5} aMussels: {1e3 * statistics.median(times):6.1f} ms/frame (max {1e3 * max(times):6.1f} ms)")


if __name__ == "__main__":
    main()
