"""What the operator console shows: the link's registry now, its history, and the mission events.

One model for the live console and for replay: it reads the one `VehicleRegistry` the link (or,
in replay, the recorded .tlog) feeds, takes the mission loop's events, extends the plots once per
second of mission time (`sample(t_s)`), and hands the UI a frozen `Snapshot` it can read from any
thread. The movement cost is the registry's (aPad-to-setpoint distance per Go To seen on the
link, the paper's definition), so a replay shows the figure the live run did.

With several aPads it follows each (position, trace, phase, slots, its share of the fleet); the
snapshot's single-aPad fields are the selected aPad's, so one screen serves one aPad or a swarm.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from apad_sitl.vocabulary import Primitive, RoverMode
from gcs.link.registry import VehicleRegistry, VehicleView
from gcs.link.telemetry import PrimitiveView
from gcs.view.columns import FleetColumns, Growing
from gcs.view.snapshot import ApadSnapshot, SlotSnapshot, Snapshot
from missiontime import mm_ss
from mussel_sim.vocabulary import MusselState

TRACE_SAMPLES = 300  # the aPad's recent trace: this many 1 Hz samples
# Why a mission ended (`gcs.loop.control.EndReason`), as the console says it.
END_WORDS = {"mission time": "its time is up", "aPad battery": "the aPad's battery reached its end threshold",
             "operator stop": "the operator stopped it"}


class MissionEvent(Protocol):
    """One mission event as the model reads it (the records' `Event` is one): read, never imported,
    so this package stays below the records."""

    @property
    def t_s(self) -> float: ...  # mission time

    @property
    def kind(self) -> str: ...

    @property
    def fields(self) -> Mapping[str, Any]: ...


QUIET_PHASES = frozenset({"idle wait", "plan collection", "plan redeployment"})  # not in the event log shown


class MissionView:
    """The console's view of the aPads and the fleet: current state read from the link's registry,
    history sampled once per second of mission time, the mission loops' events."""

    def __init__(
        self,
        registry: VehicleRegistry,
        apad_id: int,
        pool_threshold: float,
        duration_s: float,
        source: str,
        mussel_ids: NDArray[np.int64] | None = None,
        outline: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None,
        apad_ids: Sequence[int] = (),
        sinking_counts_active: bool = True,
    ) -> None:
        """`apad_ids`: every aPad to follow (default `apad_id` alone), the first one selected;
        `sinking_counts_active` as the scenario's option (the recorder counts uptime the same way)."""
        self.registry = registry
        self.apad_id = apad_id
        self.apad_ids = tuple(apad_ids) or (apad_id,)
        self.pool_threshold = pool_threshold
        self.duration_s = duration_s
        self.source = source
        self.outline = outline or (np.zeros(0), np.zeros(0))
        self.ids = np.zeros(0, np.int64) if mussel_ids is None else np.sort(np.asarray(mussel_ids, np.int64))
        self.measuring = [MusselState.ACTIVE, MusselState.SINKING] if sinking_counts_active else [MusselState.ACTIVE]
        n = self.ids.size
        self.active_samples = np.zeros(n, np.int64)
        self.samples = 0
        m = len(self.apad_ids)
        self.strategy = "-"
        self.log: list[str] = []
        self.loops = {a: _LoopTrack() for a in self.apad_ids}  # what each aPad's loop said
        self.owner: dict[int, int] = {}  # aMussel -> the aPad whose share it is (a swarm's)
        self.hist_t = Growing(0, np.float64)
        self.hist_active = Growing(0, np.int32)
        self.hist_battery = Growing(n, np.float32, np.nan)
        self.hist_apad_v = Growing(m, np.float64, np.nan)  # (k, m): a column per aPad
        self.trace_lat = Growing(m, np.float64, np.nan)
        self.trace_lon = Growing(m, np.float64, np.nan)
        self._own_version = 0
        self._fleet: tuple[int, FleetColumns] | None = None  # (table version, columns) last gathered

    @property
    def version(self) -> int:
        """Changes whenever anything the screen shows may have changed."""
        return self.registry.version + self._own_version

    # --- input -------------------------------------------------------------------------------

    def fleet(self) -> FleetColumns:
        """Every aMussel's latest report, in this model's column order (newcomers join at the end)."""
        table = self.registry.mussels
        cached = self._fleet
        if cached is not None and cached[0] == table.version:
            return cached[1]
        new = np.setdiff1d(table.ids, self.ids)
        if new.size:  # real aMussels joining: every per-aMussel column grows
            self.ids = np.concatenate([self.ids, new])
            self.active_samples = np.concatenate([self.active_samples, np.zeros(new.size, np.int64)])
            self.hist_battery.widen(self.ids.size)
        cols = FleetColumns.of(table, self.ids)
        self._fleet = (table.version, cols)
        return cols

    def _heard_age_s(self, cols: FleetColumns, t_s: float) -> NDArray[np.float64]:
        """Seconds since each report was made: a simulated aMussel's report carries our clock's time; a
        real one's, its own, so its age counts from when we heard it (`mussel_heard_us`)."""
        report_us = cols.report_us.astype(np.float64)
        heard = self.registry.mussel_heard_us
        for k in np.flatnonzero(~cols.simulated):
            report_us[k] = heard.get(int(self.ids[k]), -1)
        return np.where(report_us >= 0, np.maximum(t_s - report_us / 1e6, 0.0), np.nan)

    def event(self, ev: MissionEvent) -> None:
        f = ev.fields
        loop = self.loops.get(int(f.get("apad", self.apad_ids[0])))  # a swarm's loops name their aPad
        if loop is not None:
            loop.event(ev)
        if ev.kind == "reshare" and isinstance(f.get("shares"), dict):  # replay learns the sharing here
            owner = {m: int(a) for a, ids in f["shares"].items() if str(a).isdigit() and isinstance(ids, list)
                     for m in ids if type(m) is int}
            self.set_owner(owner)
        if ev.kind in ("mission_start", "plan_collection") and "strategy" in f:
            self.strategy = str(f["strategy"])
        elif ev.kind == "strategy_switch":
            self.strategy = str(f.get("new", self.strategy))
        # Not the idle wait (it repeats every cycle), nor the planning phases: their plan's own event
        # follows at once and says more (the strategy, the route), so each plan is one line.
        if ev.kind != "phase" or f.get("phase") not in QUIET_PHASES:
            self.log.append(_event_text(ev))
            del self.log[:-50]
        self._own_version += 1

    def set_owner(self, owner: Mapping[int, int]) -> None:
        """A swarm's sharing of the fleet (`FleetShares.owner`), copied."""
        self.owner = dict(owner)
        self._own_version += 1

    def sample(self, t_s: float) -> None:
        """One point on every plot; uptime counts measuring samples (eq. 3 over the mission so far)."""
        cols = self.fleet()
        active = np.isin(cols.state, self.measuring)
        self.active_samples += active
        self.samples += 1
        views = [self.registry.vehicles.get(a) for a in self.apad_ids]
        self.hist_t.append(t_s)
        self.hist_active.append(int(np.count_nonzero(active)))
        self.hist_battery.append(cols.battery_frac)
        self.hist_apad_v.append([np.nan if v is None or v.battery_v is None else v.battery_v for v in views])
        self.trace_lat.append([np.nan if v is None or v.lat_deg is None else v.lat_deg for v in views])
        self.trace_lon.append([np.nan if v is None or v.lon_deg is None else v.lon_deg for v in views])
        self._own_version += 1

    # --- output ------------------------------------------------------------------------------

    def snapshot(self, t_s: float, selected: int | None = None, **extra: Any) -> Snapshot:
        """A frozen copy of the model, the aPad fields of `selected` (default the first aPad);
        `extra` sets the operator fields (paused, notice, ...)."""
        cols = self.fleet()
        uptime = 100.0 * self.active_samples / self.samples if self.samples else np.zeros(self.ids.size)
        owner = np.array([self.owner.get(int(m), 0) for m in self.ids], np.int64)
        apads = tuple(self._apad(i, owner) for i in range(len(self.apad_ids)))
        column = self.apad_ids.index(selected) if selected in self.apad_ids else 0
        a = apads[column]
        ended = all(loop.ended is not None for loop in self.loops.values())
        return Snapshot(
            version=self.version,
            t_s=max(loop.ended_t_s for loop in self.loops.values()) if ended else t_s,  # the clock stops at the end
            duration_s=self.duration_s,
            source=self.source,
            pool_threshold=self.pool_threshold,
            mussel_ids=self.ids.copy(),
            lat_deg=cols.lat_deg,  # gathered afresh for each registry version: never written again
            lon_deg=cols.lon_deg,
            battery_frac=cols.battery_frac,
            state=cols.state,
            heard_age_s=self._heard_age_s(cols, t_s),
            uptime_pct=np.asarray(uptime, np.float64).copy(),
            strategy=self.strategy,
            # History rows are written once and never again: views are as good as copies.
            hist_t_s=self.hist_t.rows(),
            hist_active=self.hist_active.rows(),
            hist_battery=self.hist_battery.rows(),
            hist_apad_v=self.hist_apad_v.rows()[:, column],
            log=tuple(self.log[-8:]),
            # The mission has ended when every aPad's loop has.
            ended=None if any(x.ended is None for x in apads) else a.ended,
            outline_lat_deg=self.outline[0],
            outline_lon_deg=self.outline[1],
            apads=apads,
            selected=a.system_id,
            owner=owner,
            **extra,
        )

    def _apad(self, column: int, owner: NDArray[np.int64]) -> ApadSnapshot:
        sysid = self.apad_ids[column]
        view = self.registry.vehicles.get(sysid) or VehicleView(sysid)
        heard = sysid in self.registry.vehicles
        loop = self.loops[sysid]
        k0 = max(self.trace_lat.n - TRACE_SAMPLES, 0)
        return ApadSnapshot(
            system_id=sysid,
            heard=heard,
            lat_deg=view.lat_deg,
            lon_deg=view.lon_deg,
            trace_lat_deg=self.trace_lat.rows()[k0:, column].copy(),
            trace_lon_deg=self.trace_lon.rows()[k0:, column].copy(),
            battery_v=view.battery_v,
            battery_pct=view.battery_pct,
            mode=_mode_name(view.custom_mode) if heard else "-",
            primitive=_primitive_text(view.primitive) if heard else "-",
            slots=tuple(SlotSnapshot(s.slot, s.mussel_id, s.latch.name, s.charging) for s in view.slots.values()),
            phase=loop.phase,
            cycles=loop.cycles,
            cost_m=view.goto_cost_m,
            share=tuple(int(m) for m in self.ids[owner == sysid]),
            ended=loop.ended,
        )


class _LoopTrack:
    """What one aPad's loop has said in its events: its phase, its cycles, why it ended."""

    def __init__(self) -> None:
        self.phase = "-"
        self.cycles = 0
        self.ended: str | None = None
        self.ended_t_s = 0.0
        self._redeploying = False

    def event(self, ev: MissionEvent) -> None:
        if ev.kind == "phase":
            self.phase = str(ev.fields.get("phase", "-"))
            # A cycle is complete when the loop is back to idle after a redeployment.
            if self.phase == "idle wait" and self._redeploying:
                self.cycles += 1
                self._redeploying = False
        elif ev.kind == "plan_redeployment":
            self._redeploying = True
        elif ev.kind == "mission_end":
            self.ended = str(ev.fields.get("reason", "ended"))
            self.ended_t_s = ev.t_s


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


def _mode_name(custom_mode: int) -> str:
    return RoverMode(custom_mode).name if custom_mode in RoverMode.__members__.values() else str(custom_mode)


def _primitive_text(p: PrimitiveView) -> str:
    progress = p.progress.name.replace("_", " ").lower()
    if p.primitive == Primitive.GOTO:
        return f"GOTO {progress}, {p.distance_to_go_m:.1f} m to go"
    if p.primitive in (Primitive.DOCK, Primitive.UNDOCK):
        return f"{p.primitive.name} slot {p.slot} aMussel {p.mussel_id} {progress}"
    return f"{p.primitive.name} {progress}"


def _event_text(ev: MissionEvent) -> str:
    f = dict(ev.fields)
    who = f"aPad {f.pop('apad')}: " if "apad" in f else ""  # a swarm's loops name their aPad
    if ev.kind == "phase":
        body = str(f.get("phase"))
    elif ev.kind in ("operator", "refused"):  # the operator's actions, and what was refused, in words
        action = str(f.pop("action", ""))
        why = f.pop("why", None)
        f.pop("result", None)
        names = {"mussel": "aMussel"}
        # A field named as the action is its new value: "operator strategy -> weighted", said once.
        body = f"{ev.kind} {action}: {why}" if why else " ".join(
            [ev.kind, action, *(f"-> {v}" if k == action else f"{names.get(k, k)} {v}" for k, v in f.items())])
    elif ev.kind == "apad_restart":
        body = "aPad restarted" + (f", held {f['held']} before" if f.get("held") else "")
    elif ev.kind == "mission_end":
        body = f"mission ended: {END_WORDS.get(str(f.get('reason')), f.get('reason'))}"
    elif "mussel" in f:
        body = f"{ev.kind} aMussel {f['mussel']}" + (f" slot {f['slot']}" if "slot" in f else "")
        if "why" in f:
            body += f" ({f['why']})"
    elif "route" in f:
        body = f"{ev.kind} {f.get('strategy', '')} {f['route']}"
    else:
        body = " ".join([ev.kind, *(f"{k}={v}" for k, v in f.items())])
    return f"{mm_ss(ev.t_s)} {who}{body}"
