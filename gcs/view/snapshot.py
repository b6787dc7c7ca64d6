"""The records the console screen reads: one frozen `Snapshot` per frame, an `ApadSnapshot` per aPad
(with its `SlotSnapshot`s), and the `MarkerColour` classes of the map markers.

`gcs.view.model.MissionView` builds them; the UI reads them from any thread. The snapshot's
single-aPad fields are the selected aPad's, so one screen serves one aPad or a swarm.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from mussel_sim.vocabulary import MusselState


class MarkerColour:
    """Map marker classes, in drawing order (later wins a shared cell)."""

    CHARGED = 0  # active, above the pool threshold: green
    CANDIDATE = 1  # active, below the pool threshold: red
    DEPLETED = 2  # grey
    DOCKED = 3  # docked or charging: purple


@dataclass(frozen=True)
class SlotSnapshot:
    slot: int
    mussel_id: int
    latch: str
    charging: bool


@dataclass(frozen=True)
class ApadSnapshot:
    """One aPad as the console shows it; `share`: the aMussels it serves (its owner's share)."""

    system_id: int
    heard: bool
    lat_deg: float | None
    lon_deg: float | None
    trace_lat_deg: NDArray[np.float64]
    trace_lon_deg: NDArray[np.float64]
    battery_v: float | None
    battery_pct: int
    mode: str
    primitive: str
    slots: tuple[SlotSnapshot, ...]
    phase: str
    cycles: int
    cost_m: float
    share: tuple[int, ...]
    ended: str | None


# Knowledge older than this is stale (its row marked): a surfaced aMussel reports every keep-alive window
# (5 s; at once when its state changes: `mussel_sim.report_policy`), an
# acoustic one in its TDMA slot once a frame (17 s in pool12-acoustic, 34 s in bay24-acoustic), so an
# age past a minute means reports were lost or it has fallen silent.
STALE_S = 60.0


def age_text(age_s: float) -> str:
    """How old a report is, in at most 5 characters: "-" never heard, "now", "17s", "12m", "3h", and a
    trailing "!" once it is stale (`STALE_S`)."""
    if age_s != age_s:  # NaN
        return "-"
    if age_s < 1.5:
        return "now"
    text = f"{age_s:.0f}s" if age_s < 600 else f"{age_s / 60:.0f}m" if age_s < 36_000 else f"{age_s / 3600:.0f}h"
    return text + "!" if age_s > STALE_S else text


@dataclass(frozen=True)
class Snapshot:
    """One frame of the console. Arrays are copies `(n,)` ordered by aMussel id, or `(k,)` over samples."""

    version: int
    t_s: float  # mission time
    duration_s: float
    source: str
    pool_threshold: float
    mussel_ids: NDArray[np.int64]
    lat_deg: NDArray[np.float64]
    lon_deg: NDArray[np.float64]
    battery_frac: NDArray[np.float64]
    state: NDArray[np.uint8]  # MusselState
    uptime_pct: NDArray[np.float64]
    strategy: str
    hist_t_s: NDArray[np.float64]  # (k,) sample times
    hist_active: NDArray[np.int32]  # (k,) active aMussels per sample
    hist_battery: NDArray[np.float32]  # (k, n) battery fraction, NaN before first heard
    hist_apad_v: NDArray[np.float64]  # (k,) the selected aPad's battery volts, NaN unknown
    apads: tuple[ApadSnapshot, ...]  # every aPad, in the scenario's order
    selected: int  # the system id of the aPad shown in detail and commanded
    log: tuple[str, ...] = ()
    paused: bool = False
    pending_strategy: str | None = None
    ended: str | None = None
    notice: str = ""
    dropped: int = 0  # received messages the link refused so far (validation, spoofs, strangers)
    dropped_top: str = ""  # the commonest reason, "REASON ×N"
    outline_lat_deg: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    outline_lon_deg: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    owner: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, np.int64))  # (n,) aPad, 0: none
    # (n,) mission seconds since each aMussel's last report was made, NaN: never heard (`STALE_S`)
    heard_age_s: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))

    # The selected aPad, as the one-aPad screens read it (one record per aPad: `apads`).
    @property
    def apad(self) -> ApadSnapshot:
        return next(a for a in self.apads if a.system_id == self.selected)

    @property
    def apad_lat_deg(self) -> float | None:
        return self.apad.lat_deg

    @property
    def apad_lon_deg(self) -> float | None:
        return self.apad.lon_deg

    @property
    def trace_lat_deg(self) -> NDArray[np.float64]:
        return self.apad.trace_lat_deg

    @property
    def trace_lon_deg(self) -> NDArray[np.float64]:
        return self.apad.trace_lon_deg

    @property
    def apad_battery_v(self) -> float | None:
        return self.apad.battery_v

    @property
    def apad_battery_pct(self) -> int:
        return self.apad.battery_pct

    @property
    def mode(self) -> str:
        return self.apad.mode

    @property
    def primitive(self) -> str:
        return self.apad.primitive

    @property
    def slots(self) -> tuple[SlotSnapshot, ...]:
        return self.apad.slots

    @property
    def phase(self) -> str:
        return self.apad.phase

    @property
    def cost_m(self) -> float:
        return self.apad.cost_m

    @property
    def cycles(self) -> int:
        return self.apad.cycles

    def marker_classes(self) -> NDArray[np.int8]:
        """`MarkerColour` per aMussel `(n,)`."""
        out = np.full(self.mussel_ids.size, MarkerColour.CHARGED, np.int8)
        out[self.battery_frac < self.pool_threshold] = MarkerColour.CANDIDATE
        out[self.state == MusselState.DEPLETED] = MarkerColour.DEPLETED
        out[self.state == MusselState.DOCKED] = MarkerColour.DOCKED
        return out
