"""The TDMA frame: one slot per aMussel, then one per aPad, each long enough for the longest packet
to cross the whole area, plus a guard.

slot = airtime(longest packet) + largest propagation delay over the area + guard; the frame is the
slots end to end, repeating from mission time 0. Pure: the area comes in as its largest range, in
metres (`largest_range_m` of a polygon's local coordinates).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum

import numpy as np
from numpy.typing import ArrayLike

from acoustic.airtime import airtime_s
from acoustic.params import AcousticParams
from missiontime import US_PER_S


class Owner(Enum):
    AMUSSEL = "amussel"
    APAD = "apad"


@dataclass(frozen=True)
class Slot:
    index: int
    owner: Owner
    node_id: int  # aMussel id or aPad system id
    start_s: float  # from the frame's start
    end_s: float


@dataclass(frozen=True)
class TdmaFrame:
    slot_s: float
    packet_s: float  # the longest packet's airtime
    delay_s: float  # the largest propagation delay over the area
    guard_s: float
    slots: tuple[Slot, ...]

    @property
    def frame_s(self) -> float:
        return self.slot_s * len(self.slots)

    @property
    def apad_ids(self) -> tuple[int, ...]:
        return tuple(s.node_id for s in self.slots if s.owner is Owner.APAD)

    def slot_of(self, owner: Owner, node_id: int) -> Slot:
        """The slot of one aMussel or aPad (KeyError if it has none)."""
        for slot in self.slots:
            if slot.owner is owner and slot.node_id == node_id:
                return slot
        raise KeyError(f"{owner.value} {node_id} has no slot")

    def next_slot_start_s(self, owner: Owner, node_id: int, t_s: float) -> float:
        """The first start of this node's slot at or after mission time `t_s`."""
        offset = self.slot_of(owner, node_id).start_s
        k = math.ceil((t_s - offset) / self.frame_s - 1e-12)
        return offset + max(k, 0) * self.frame_s

    def table(self) -> list[dict[str, object]]:
        """The slot table as rows (for the run's records)."""
        return [{"slot": s.index, "owner": s.owner.value, "id": s.node_id, "start_s": s.start_s, "end_s": s.end_s}
                for s in self.slots]


def largest_range_m(points_m: ArrayLike, depth_m: float = 0.0) -> float:
    """The largest distance between two of the (n, 2) points (a polygon's vertices: its diameter),
    with `depth_m` of vertical separation on top (a node on the seabed to one at the surface)."""
    pts = np.asarray(points_m, dtype=np.float64).reshape(-1, 2)
    horizontal = float(np.linalg.norm(pts[:, None, :] - pts[None, :, :], axis=-1).max())  # a polygon's few vertices
    return math.hypot(horizontal, depth_m)


def tdma_frame(mussel_ids: ArrayLike, apad_ids: ArrayLike, area_range_m: float, params: AcousticParams) -> TdmaFrame:
    """The frame of a fleet (aMussels in id order, then the aPads) over an area whose largest range is
    `area_range_m`; a slot holds a packet of `params.max_packet_bytes`."""
    mussels = sorted(int(i) for i in np.asarray(mussel_ids).ravel())
    apads = sorted(int(i) for i in np.asarray(apad_ids).ravel())
    if len(set(mussels)) != len(mussels) or len(set(apads)) != len(apads):
        raise ValueError("ids must differ within the aMussels and within the aPads")
    if not (math.isfinite(area_range_m) and area_range_m >= 0):
        raise ValueError(f"area range must be a finite non-negative number, got {area_range_m}")
    packet = airtime_s(params.max_packet_bytes)
    delay = area_range_m / params.sound_speed_mps
    # A whole number of microseconds: the fleet's slot task runs on the mission clock's microseconds and
    # the GCS's uplink counts slots in seconds from mission time 0; equal steps keep them together for
    # a mission of months (rounding each slot apart would drift ~0.5 us a slot: a second in 90 days).
    slot_s = math.ceil((packet + delay + params.guard_s) * US_PER_S) / US_PER_S
    owners = [(Owner.AMUSSEL, i) for i in mussels] + [(Owner.APAD, i) for i in apads]
    slots = tuple(Slot(k, owner, node, k * slot_s, (k + 1) * slot_s) for k, (owner, node) in enumerate(owners))
    return TdmaFrame(slot_s, packet, delay, params.guard_s, slots)
