"""Time to render one console frame with 12, 200 and 1,000 aMussels.

    .venv/bin/python bench/tui_frame.py

The fleet is the real model (mussel_sim) drawn in the bay area and stepped for 10 simulated
minutes; its statuses reach the link's registry one batch a second, as the router puts them, and
one aPad crosses the area with docked aMussels in its slots. A frame = the app taking a new 1 Hz
snapshot and Textual compositing the whole 160x48 screen (map, table, status, three plots),
headless. Printed: the median wall time and the median CPU time of this thread (the steadier
figure on a shared machine). Targets: 10 ms at 200 aMussels, 30 ms at 1,000; the budget at
10 fps is 100 ms.
"""

from __future__ import annotations

import asyncio
import statistics
import time
from pathlib import Path

import numpy as np

from apad_sitl.vocabulary import N_SLOTS, Latch
from gcs.console.app import ConsoleApp
from gcs.link.fleet_table import MusselBatch
from gcs.link.registry import VehicleRegistry
from gcs.link.telemetry import DEG_E7, Heartbeat, Position, SlotView
from gcs.view.model import MissionView, area_outline
from gcs.view.snapshot import Snapshot
from mussel_sim.fleet import step
from mussel_sim.fleet_state import FleetInputs, FleetParams, initial_state
from mussel_sim.placement import load_area
from mussel_sim.startconfig import generate_start_config
from mussel_sim.vocabulary import MusselState

BAY = Path(__file__).resolve().parents[1] / "missions" / "areas" / "bay.geojson"
SIZE = (160, 48)
FRAMES = 30
APAD_ID = 1


def snapshots(n: int, count: int) -> list[Snapshot]:
    """`count` successive 1 Hz snapshots of an n-aMussel fleet, after a 600 s history.

    The statuses reach the link's registry as the router puts them there (one batch per second);
    one aPad crosses the area with its first slots holding docked aMussels."""
    area = load_area(BAY)
    frame = area.frame()
    rng = np.random.default_rng(1)
    config = generate_start_config(area, n, frame, rng)
    params = FleetParams()
    state = initial_state(config, frame, params)
    registry = VehicleRegistry()
    model = MissionView(registry, APAD_ID, 0.8, 2400.0, "bench", config.ids.astype(np.int64),
                         area_outline(area.geometry))
    docked = state.ids[: min(N_SLOTS, n)].astype(np.int64)
    registry.apply(APAD_ID, Heartbeat(4, True), 0)
    for slot, mussel in enumerate(docked, start=1):
        registry.apply(APAD_ID, SlotView(slot, int(mussel), Latch.LATCHED, True), 0)
    out = []
    for k in range(600 + count):
        state, _ = step(state, FleetInputs.make(), params, rng, 1.0)
        ax, ay = frame.to_geodetic(-300.0 + k, 100.0 * np.sin(k / 60))
        registry.apply(APAD_ID, Position(float(ax), float(ay), 90.0), k * 1_000_000)
        lat, lon = frame.to_geodetic(state.x_m, state.y_m)
        states = state.state.astype(np.int64)
        states[: docked.size] = MusselState.DOCKED
        lat[: docked.size], lon[: docked.size] = ax, ay  # a docked aMussel reports the aPad's position
        registry.mussels.update_batch(MusselBatch.from_wire({
            "mussel_id": state.ids, "lat": np.round(lat * DEG_E7), "lon": np.round(lon * DEG_E7), "depth": 3.0,
            "battery": state.battery_frac, "battery_voltage": 4000, "state": states, "simulated": 1,
            "time_us": state.time_us}))
        registry.version += 1
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


async def frame_times(frames: list[Snapshot]) -> tuple[list[float], list[float]]:
    """Per frame: wall seconds and this thread's CPU seconds (steadier on a shared machine)."""
    app = BenchApp(frames)
    wall, cpu = [], []
    async with app.run_test(size=SIZE) as pilot:
        await pilot.pause(0.2)
        for i in range(1, len(frames)):
            app.index = i
            t0, c0 = time.perf_counter(), time.thread_time()
            app.redraw()
            # Composite every widget to strips, as a refresh to the terminal does.
            app.screen._compositor.render_strips()
            wall.append(time.perf_counter() - t0)
            cpu.append(time.thread_time() - c0)
            await pilot.pause()
    return wall, cpu


def main() -> None:
    print(f"console frame, {SIZE[0]}x{SIZE[1]} cells, median of {FRAMES - 1} frames (budget 100 ms at 10 fps)")
    for n in (12, 200, 1000):
        frames = snapshots(n, FRAMES)
        wall, cpu = asyncio.run(frame_times(frames))
        print(f"{n:>5} aMussels: {1e3 * statistics.median(wall):6.1f} ms/frame wall (max {1e3 * max(wall):6.1f}), "
              f"{1e3 * statistics.median(cpu):6.1f} ms CPU")


if __name__ == "__main__":
    main()
