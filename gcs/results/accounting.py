"""Where every aMussel is at the end of a mission, checked against what the GCS believes.

Nothing may be lost silently: each aMussel is at a position on the seabed (its start or where it
was redeployed, or where it is still working), on a known aPad slot (the fleet and the aPad's slot
report agree), or reported lost with a reason. One whose battery gave out while it was called up
stays where that happened: at the surface, or in the water on its way up; it is reported there.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from apad_sitl.vocabulary import Latch
from gcs.link.registry import VehicleView
from mussel_sim.fleet_state import FleetState
from mussel_sim.geo import LocalFrame
from mussel_sim.vocabulary import MusselState

# Farther than this from where it started or was put back, a submerged aMussel is somewhere unexpected.
HOME_TOLERANCE_M = 10.0
SURFACE_DEPTH_M = 0.01  # a depleted aMussel this shallow is at the surface (floating ones are at 0 m)


@dataclass(frozen=True)
class MusselAccount:
    mussel_id: int
    where: str  # "seabed", "slot", "surface" or "water" (depleted on its way up), "lost"
    detail: str  # slot number, distance from home, or the reason it is lost

    @property
    def lost(self) -> bool:
        return self.where == "lost"


def account(
    fleet: FleetState, frame: LocalFrame, homes_deg: dict[int, tuple[float, float]], apads: dict[int, VehicleView],
    seabed_depth_m: float | None = None, reported: Mapping[int, str] | None = None,
) -> list[MusselAccount]:
    """One entry per aMussel, from the fleet's own state and the aPads' slot reports. With
    `seabed_depth_m` a depleted aMussel above the seabed is told apart ("water") from one on it;
    `reported`: why the loop left an aMussel off its position, said beside it if it ends there."""
    reported = reported or {}
    ids = [int(i) for i in fleet.ids]
    home_lat = np.array([homes_deg[i][0] for i in ids])
    home_lon = np.array([homes_deg[i][1] for i in ids])
    hx, hy = frame.to_local(home_lat, home_lon)
    out = []
    for k, mussel_id in enumerate(ids):
        state = MusselState(int(fleet.state[k]))
        if state == MusselState.DOCKED:
            apad, slot = int(fleet.dock_apad[k]), int(fleet.dock_slot[k])
            view = apads.get(apad)
            seen = view.slots.get(slot) if view is not None else None
            if seen is not None and seen.mussel_id == mussel_id and seen.latch != Latch.OPEN:
                out.append(MusselAccount(mussel_id, "slot", f"aPad {apad} slot {slot}"))
            else:
                out.append(MusselAccount(mussel_id, "lost", f"docked on aPad {apad} slot {slot}, unknown to the GCS"))
        elif state in (MusselState.FLOATING, MusselState.SURFACING):
            out.append(MusselAccount(mussel_id, "lost", f"left {state.name.lower()} at the surface"))
        else:
            off_m = float(np.hypot(fleet.x_m[k] - hx[k], fleet.y_m[k] - hy[k]))
            where, what = "seabed", state.name.lower()
            if state == MusselState.DEPLETED:
                where = _depleted_where(float(fleet.depth_m[k]), seabed_depth_m)
                what = {"surface": "depleted at the surface", "water": f"depleted {fleet.depth_m[k]:.1f} m deep",
                        "seabed": "depleted"}[where]
            if off_m > HOME_TOLERANCE_M:
                why = f" ({reported[mussel_id]})" if mussel_id in reported else ""
                out.append(MusselAccount(mussel_id, "lost", f"{what} {off_m:.1f} m from its position{why}"))
            else:
                out.append(MusselAccount(mussel_id, where, f"{what}, {off_m:.2f} m from its position"))
    return out


def _depleted_where(depth_m: float, seabed_depth_m: float | None) -> str:
    if depth_m <= SURFACE_DEPTH_M:
        return "surface"
    if seabed_depth_m is not None and depth_m < seabed_depth_m - SURFACE_DEPTH_M:
        return "water"
    return "seabed"
