"""What the operator console shows, built from what crossed the GCS link plus the mission events.

One model for the live console and for replay: feed it every MAVLink message the GCS saw (the
same stream its .tlog records: aMussel statuses, aPad telemetry, the GCS's own commands) and the
mission loop's events; call `sample(t_s)` once per second of mission time to extend the plots;
`snapshot(t_s)` returns a frozen `Snapshot` the UI can read from any thread.

The movement cost is computed from the Go To commands seen on the link (aPad position to
setpoint), the paper's definition, so a replay shows the same figure the live run did.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from apad_sitl.vocabulary import Latch, Primitive, Progress
from gcs.records.events import Event
from mavlink_dialect import mavlink
from mussel_sim.geo import distance_m
from mussel_sim.vocabulary import MusselState

TRACE_SAMPLES = 300  # the aPad's recent trace: this many 1 Hz samples
MODE_NAMES = {4: "HOLD", 15: "GUIDED"}  # ArduRover custom modes the aPad uses


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
    apad_lat_deg: float | None
    apad_lon_deg: float | None
    trace_lat_deg: NDArray[np.float64]
    trace_lon_deg: NDArray[np.float64]
    apad_battery_v: float | None
    apad_battery_pct: int
    mode: str
    primitive: str
    slots: tuple[SlotSnapshot, ...]
    phase: str
    strategy: str
    cost_m: float
    cycles: int
    hist_t_s: NDArray[np.float64]  # (k,) sample times
    hist_active: NDArray[np.int32]  # (k,) active aMussels per sample
    hist_battery: NDArray[np.float32]  # (k, n) battery fraction, NaN before first heard
    hist_apad_v: NDArray[np.float64]  # (k,) aPad battery volts, NaN unknown
    log: tuple[str, ...] = ()
    paused: bool = False
    pending_strategy: str | None = None
    ended: str | None = None
    notice: str = ""
    outline_lat_deg: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    outline_lon_deg: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))

    def marker_classes(self) -> NDArray[np.int8]:
        """`MarkerColour` per aMussel `(n,)`."""
        out = np.full(self.mussel_ids.size, MarkerColour.CHARGED, np.int8)
        out[self.battery_frac < self.pool_threshold] = MarkerColour.CANDIDATE
        out[self.state == MusselState.DEPLETED] = MarkerColour.DEPLETED
        out[self.state == MusselState.DOCKED] = MarkerColour.DOCKED
        return out


class _Growing:
    """Append-only rows; written rows never change, so views of them are safe to hand out."""

    def __init__(self, width: int, dtype: Any, fill: float = 0.0) -> None:
        self.fill = fill
        self.data = np.full((256, width) if width else (256,), fill, dtype)
        self.n = 0

    def append(self, row: Any) -> None:
        if self.n == self.data.shape[0]:
            bigger = np.full((2 * self.n, *self.data.shape[1:]), self.fill, self.data.dtype)
            bigger[: self.n] = self.data
            self.data = bigger  # old views keep the old buffer
        self.data[self.n] = row
        self.n += 1

    def widen(self, width: int) -> None:
        grown = np.full((self.data.shape[0], width), self.fill, self.data.dtype)
        grown[:, : self.data.shape[1]] = self.data
        self.data = grown

    def rows(self, k: int | None = None) -> NDArray[Any]:
        return self.data[: self.n if k is None else k]


class ConsoleModel:
    def __init__(
        self,
        apad_id: int,
        pool_threshold: float,
        duration_s: float,
        source: str,
        mussel_ids: NDArray[np.int64] | None = None,
        outline: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None,
    ) -> None:
        self.apad_id = apad_id
        self.pool_threshold = pool_threshold
        self.duration_s = duration_s
        self.source = source
        self.outline = outline or (np.zeros(0), np.zeros(0))
        ids = np.zeros(0, np.int64) if mussel_ids is None else np.sort(np.asarray(mussel_ids, np.int64))
        self.ids = ids
        self._col = {int(i): c for c, i in enumerate(ids)}
        n = ids.size
        self.lat = np.full(n, np.nan)
        self.lon = np.full(n, np.nan)
        self.battery = np.full(n, np.nan)
        self.state = np.full(n, MusselState.ACTIVE, np.uint8)
        self.active_samples = np.zeros(n, np.int64)
        self.samples = 0
        self.apad_lat: float | None = None
        self.apad_lon: float | None = None
        self.apad_v: float | None = None
        self.apad_pct = -1
        self.mode = "-"
        self.primitive = "-"
        self.slots = {s: SlotSnapshot(s, 0, Latch.OPEN.name, False) for s in range(1, 5)}
        self.phase = "-"
        self.strategy = "-"
        self.cost_m = 0.0
        self.cycles = 0
        self.ended: str | None = None
        self.log: list[str] = []
        self._last_goto: tuple[int, int] | None = None
        self._redeploying = False
        self.hist_t = _Growing(0, np.float64)
        self.hist_active = _Growing(0, np.int32)
        self.hist_battery = _Growing(n, np.float32, np.nan)
        self.hist_apad_v = _Growing(0, np.float64, np.nan)
        self.trace_lat = _Growing(0, np.float64, np.nan)
        self.trace_lon = _Growing(0, np.float64, np.nan)
        self.version = 0  # bumped on every change the screen could show

    # --- input -------------------------------------------------------------------------------

    def _column(self, mussel_id: int) -> int:
        col = self._col.get(mussel_id)
        if col is not None:
            return col
        # A newcomer (a real aMussel joining): grow every per-aMussel array by one column.
        col = self.ids.size
        self._col[mussel_id] = col
        self.ids = np.append(self.ids, mussel_id)
        self.lat, self.lon, self.battery = (np.append(a, np.nan) for a in (self.lat, self.lon, self.battery))
        self.state = np.append(self.state, np.uint8(MusselState.ACTIVE))
        self.active_samples = np.append(self.active_samples, 0)
        self.hist_battery.widen(self.ids.size)
        return col

    def handle(self, msg: mavlink.MAVLink_message) -> None:
        kind = msg.get_type()
        if kind == "AMUSSEL_STATUS":
            c = self._column(msg.mussel_id)
            self.lat[c], self.lon[c] = msg.lat / 1e7, msg.lon / 1e7
            self.battery[c] = msg.battery
            self.state[c] = msg.state
        elif msg.get_srcSystem() == self.apad_id:
            self._handle_apad(kind, msg)
        elif kind == "COMMAND_INT" and msg.command == mavlink.MAV_CMD_DO_REPOSITION:
            self._count_goto(msg)
        else:
            return
        self.version += 1

    def _handle_apad(self, kind: str, msg: Any) -> None:
        if kind == "GLOBAL_POSITION_INT":
            self.apad_lat, self.apad_lon = msg.lat / 1e7, msg.lon / 1e7
        elif kind == "HEARTBEAT":
            self.mode = MODE_NAMES.get(msg.custom_mode, str(msg.custom_mode))
        elif kind == "SYS_STATUS":
            if msg.voltage_battery != 65535:
                self.apad_v = msg.voltage_battery / 1000.0
            self.apad_pct = msg.battery_remaining
        elif kind == "PRIMITIVE_STATUS":
            self.primitive = _primitive_text(msg)
        elif kind == "DOCK_SLOT_STATUS" and 1 <= msg.slot <= 4:
            self.slots[msg.slot] = SlotSnapshot(msg.slot, msg.mussel_id, Latch(msg.latch).name, bool(msg.charging))

    def _count_goto(self, msg: Any) -> None:
        """The paper's cost: aPad-to-setpoint distance per Go To (a retried command counts once)."""
        target = (msg.x, msg.y)
        if target == self._last_goto or self.apad_lat is None or self.apad_lon is None:
            return
        self._last_goto = target
        self.cost_m += float(distance_m(self.apad_lat, self.apad_lon, msg.x / 1e7, msg.y / 1e7))

    def event(self, ev: Event) -> None:
        f = ev.fields
        if ev.kind == "phase":
            self.phase = str(f.get("phase", "-"))
            # A cycle is complete when the loop is back to idle after a redeployment.
            if self.phase == "idle wait" and self._redeploying:
                self.cycles += 1
                self._redeploying = False
        elif ev.kind in ("mission_start", "plan_collection") and "strategy" in f:
            self.strategy = str(f["strategy"])
        elif ev.kind == "strategy_switch":
            self.strategy = str(f.get("new", self.strategy))
        elif ev.kind == "plan_redeployment":
            self._redeploying = True
        elif ev.kind == "mission_end":
            self.ended = str(f.get("reason", "ended"))
        if ev.kind != "phase" or f.get("phase") != "idle wait":  # idle wait repeats every cycle
            self.log.append(_event_text(ev))
            del self.log[:-50]
        self.version += 1

    def sample(self, t_s: float) -> None:
        """One point on every plot; uptime counts ACTIVE samples (eq. 3 over the mission so far)."""
        active = self.state == MusselState.ACTIVE
        self.active_samples += active
        self.samples += 1
        self.hist_t.append(t_s)
        self.hist_active.append(int(np.count_nonzero(active)))
        self.hist_battery.append(self.battery)
        self.hist_apad_v.append(np.nan if self.apad_v is None else self.apad_v)
        self.trace_lat.append(np.nan if self.apad_lat is None else self.apad_lat)
        self.trace_lon.append(np.nan if self.apad_lon is None else self.apad_lon)
        self.version += 1

    # --- output ------------------------------------------------------------------------------

    def snapshot(self, t_s: float, **extra: Any) -> Snapshot:
        """A frozen copy of the model; `extra` sets the operator fields (paused, notice, ...)."""
        uptime = 100.0 * self.active_samples / self.samples if self.samples else np.zeros(self.ids.size)
        k0 = max(self.trace_lat.n - TRACE_SAMPLES, 0)
        return Snapshot(
            version=self.version,
            t_s=t_s,
            duration_s=self.duration_s,
            source=self.source,
            pool_threshold=self.pool_threshold,
            mussel_ids=self.ids.copy(),
            lat_deg=self.lat.copy(),
            lon_deg=self.lon.copy(),
            battery_frac=self.battery.copy(),
            state=self.state.copy(),
            uptime_pct=np.asarray(uptime, np.float64).copy(),
            apad_lat_deg=self.apad_lat,
            apad_lon_deg=self.apad_lon,
            trace_lat_deg=self.trace_lat.rows()[k0:].copy(),
            trace_lon_deg=self.trace_lon.rows()[k0:].copy(),
            apad_battery_v=self.apad_v,
            apad_battery_pct=self.apad_pct,
            mode=self.mode,
            primitive=self.primitive,
            slots=tuple(self.slots[s] for s in range(1, 5)),
            phase=self.phase,
            strategy=self.strategy,
            cost_m=self.cost_m,
            cycles=self.cycles,
            # History rows are written once and never again: views are as good as copies.
            hist_t_s=self.hist_t.rows(),
            hist_active=self.hist_active.rows(),
            hist_battery=self.hist_battery.rows(),
            hist_apad_v=self.hist_apad_v.rows(),
            log=tuple(self.log[-8:]),
            ended=self.ended,
            outline_lat_deg=self.outline[0],
            outline_lon_deg=self.outline[1],
            **extra,
        )


def area_outline(geometry: Any) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(lat, lon) of a Polygon's or MultiPolygon's exterior rings, NaN between rings."""
    polys = list(getattr(geometry, "geoms", [geometry]))
    lat: list[float] = []
    lon: list[float] = []
    for poly in polys:
        xs, ys = poly.exterior.xy
        lon += [*xs, np.nan]
        lat += [*ys, np.nan]
    return np.asarray(lat[:-1], np.float64), np.asarray(lon[:-1], np.float64)


def _primitive_text(msg: Any) -> str:
    kind = Primitive(msg.primitive).name
    progress = Progress(msg.progress).name.replace("_", " ").lower()
    if msg.primitive == Primitive.GOTO:
        return f"GOTO {progress}, {msg.distance_to_go:.1f} m to go"
    if msg.primitive in (Primitive.DOCK, Primitive.UNDOCK):
        return f"{kind} slot {msg.slot} aMussel {msg.mussel_id} {progress}"
    return f"{kind} {progress}"


def _event_text(ev: Event) -> str:
    f = ev.fields
    if ev.kind == "phase":
        body = str(f.get("phase"))
    elif "mussel" in f:
        body = f"{ev.kind} aMussel {f['mussel']}" + (f" slot {f['slot']}" if "slot" in f else "")
        if "why" in f:
            body += f" ({f['why']})"
    elif "route" in f:
        body = f"{ev.kind} {f.get('strategy', '')} {f['route']}"
    else:
        body = " ".join([ev.kind, *(f"{k}={v}" for k, v in f.items())])
    return f"{_clock(ev.t_s)} {body}"


def _clock(t_s: float) -> str:
    t = int(t_s)
    return f"{t // 60:02d}:{t % 60:02d}"
