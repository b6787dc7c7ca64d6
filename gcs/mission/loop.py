"""The energy-sharing scenario loop (the paper's Fig. 7), written on the aPad API.

Idle wait -> plan collection -> collect (go to, call up, dock) x up to 4 -> charging wait ->
plan redeployment -> redeploy (go to the original position, undock, sink) -> idle wait ...

It commands the aPad exactly as a field script would, waiting with `clock.sleep`, so the same
code runs in lockstep and in the field. The operator (console or script) controls it through
`LoopControl`: pause, stop, strategy switch. The mission ends on mission time, on the aPad
battery threshold, or on an operator stop; it never ends mid-dock.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import StrEnum

import numpy as np

from apad_sitl.vocabulary import Latch, Progress
from gcs.api import ApadApi, CommandError, GeofenceError, Location, MusselView
from gcs.link.telemetry import SlotView
from gcs.mission.planner import CostWeights, PlanInput, plan
from gcs.mission.scenario import MissionConfig
from gcs.records.events import EventLog
from missiontime import Clock
from mussel_sim.geo import distance_m
from mussel_sim.vocabulary import MusselCommand, MusselState


class Phase(StrEnum):
    IDLE_WAIT = "idle wait"
    PLAN_COLLECT = "plan collection"
    COLLECT = "collect"
    CHARGING_WAIT = "charging wait"
    PLAN_REDEPLOY = "plan redeployment"
    REDEPLOY = "redeploy"
    ENDED = "ended"


class EndReason(StrEnum):
    MISSION_TIME = "mission time"
    APAD_BATTERY = "aPad battery"
    OPERATOR = "operator stop"


class MissionEnded(Exception):
    def __init__(self, reason: EndReason) -> None:
        super().__init__(str(reason))
        self.reason = reason


@dataclass
class LoopControl:
    """What the operator may change while the loop runs (set from any thread)."""

    paused: bool = False
    stop: bool = False
    strategy: str | None = None  # a new collection strategy, taken at the next planning step
    lock: threading.Lock = field(default_factory=threading.Lock, repr=False)
    # Called before each of the loop's own waits (never inside a command's ACK wait): the console
    # runs the operator's queued commands here. True ends the mission at this wait (quit now).
    before_wait: Callable[[], bool] | None = field(default=None, repr=False)


@dataclass
class LoopStatus:
    """What the loop is doing, for the console and the results."""

    phase: Phase = Phase.IDLE_WAIT
    strategy: str = ""
    route: list[int] = field(default_factory=list)
    target_mussel: int = 0
    cost_m: float = 0.0  # the paper's movement cost: aPad-to-setpoint distance summed over Go To commands
    cycles: int = 0  # completed collect-charge-redeploy cycles
    end_reason: EndReason | None = None


@dataclass(frozen=True)
class LoopSettings:
    mission: MissionConfig
    acoustic_range_m: float
    dock_reach_m: float
    battery_end_v: float
    surfacing_timeout_s: float = 120.0  # an aMussel that does not float by then is skipped
    # No aMussel is called up later than this before the mission end: once called up it is docked
    # (or sent down again) whatever the clock says, so it is never left at the surface.
    call_up_margin_s: float = 300.0
    poll_s: float = 0.5  # how often waits look again (mission time)


class EnergySharingLoop:
    def __init__(
        self,
        api: ApadApi,
        clock: Clock,
        settings: LoopSettings,
        homes: dict[int, Location],
        apad_id: int,
        events: EventLog | None = None,
        control: LoopControl | None = None,
    ) -> None:
        self.api = api
        self.clock = clock
        self.settings = settings
        self.homes = homes  # original positions the aMussels go back to
        self.apad_id = apad_id
        self.events = events or EventLog()
        self.control = control or LoopControl()
        self.status = LoopStatus(strategy=settings.mission.collect_strategy)
        self._weights = CostWeights(settings.mission.distance_scale, settings.mission.energy_scale)

    # --- the loop ---------------------------------------------------------------------------

    def run(self, resume: bool = False) -> EndReason:
        """Run until the mission ends; the aPad is left holding, never mid-dock.

        `resume`: continue a mission whose GCS crashed (status restored from a checkpoint): first
        settle what the crash interrupted, from what the aPad and the fleet report now.
        """
        self._log("mission_resume" if resume else "mission_start", strategy=self.status.strategy)
        try:
            if resume:
                self._recover()
            while True:
                self._idle_wait()
                route = self._plan_collection()
                if route:
                    self._collect(route)
                if self._docked():
                    self._charging_wait()
                    self._redeploy(self._plan_redeployment())
                    self.status.cycles += 1
        except MissionEnded as ended:
            self.status.end_reason = ended.reason
        self._set_phase(Phase.ENDED)
        self._finish()
        assert self.status.end_reason is not None
        self._log("mission_end", reason=str(self.status.end_reason), cost_m=round(self.status.cost_m, 3))
        return self.status.end_reason

    def _recover(self) -> None:
        """After a crash: finish latches in motion, send down whatever was called up and not docked,
        and complete a charging cycle whose aMussels are still on board."""
        self._sleep(2.0, interruptible=False)  # hear the aPad's slots and the fleet's status afresh
        self._wait_until(lambda: not any(s.latch in (Latch.CLOSING, Latch.RELEASING)
                                         for s in self.api.slots(self.apad_id)), interruptible=False)
        on_board = set(self._docked().values())
        for mussel_id in self.api.mussels.select((MusselState.FLOATING, MusselState.SURFACING)):
            if mussel_id not in on_board:
                self._log("recover", mussel=mussel_id, action="sink", state=self._state(mussel_id).name)
                self._sink(mussel_id)
        if self._docked():
            self._log("recover", action="finish charging cycle", docked=sorted(on_board))
            self._charging_wait()
            self._redeploy(self._plan_redeployment())
            self.status.cycles += 1

    def _idle_wait(self) -> None:
        self._set_phase(Phase.IDLE_WAIT)
        self._command(self.api.hold)
        mission = self.settings.mission

        def pool_full() -> bool:
            if self.status.strategy == "none" or self._too_late_to_call_up():
                return False
            need = min(mission.min_pool, len(self._free_slots()))
            return need > 0 and len(self._candidates()) >= need

        self._wait_until(pool_full)

    def _plan_collection(self) -> list[int]:
        self._set_phase(Phase.PLAN_COLLECT)
        self._take_strategy_switch()
        candidates = self._candidates()
        position = self.api.position(self.apad_id)
        inp = PlanInput(
            apads={self.apad_id: (position.lat, position.lon)},
            capacity={self.apad_id: len(self._free_slots())},
            mussel_ids=np.array([m.mussel_id for m in candidates], np.int64),
            lat_deg=np.array([m.location.lat for m in candidates]),
            lon_deg=np.array([m.location.lon for m in candidates]),
            battery_frac=np.array([m.battery_frac for m in candidates]),
        )
        route = plan(self.status.strategy, inp, self._weights)[self.apad_id]
        self.status.route = route
        self._log("plan_collection", strategy=self.status.strategy, route=route)
        return route

    def _collect(self, route: list[int]) -> None:
        self._set_phase(Phase.COLLECT)
        for mussel_id in route:
            self._check_end()  # between aMussels nothing is half done: an operator stop ends here
            free = self._free_slots()
            if not free:
                break
            if self._too_late_to_call_up():
                self._log("skip", mussel=mussel_id, why="too close to the mission end to dock it")
                break
            self.status.target_mussel = mussel_id
            called = self._call_up_if_in_range(mussel_id)
            # From a call-up on, the waits ignore the mission end: the margin above leaves time to finish.
            if not self._go_to(self.api.get_location(mussel_id), interruptible=not called):
                if called:
                    self._sink(mussel_id)
                continue
            if not called and not self._call_up_if_in_range(mussel_id):
                self._log("skip", mussel=mussel_id, why="no aPad within acoustic range")
                continue
            if not self._wait_until(lambda m=mussel_id: self._state(m) == MusselState.FLOATING,
                                    self.settings.surfacing_timeout_s, interruptible=False):
                self._log("skip", mussel=mussel_id, why="did not surface", state=self._state(mussel_id).name)
                self._sink(mussel_id)  # it may surface later: it must not float there forever
                continue
            # It surfaced where it was last localised underwater, give or take drift: close in.
            if self._distance_to(mussel_id) > 0.8 * self.settings.dock_reach_m:
                self._go_to(self.api.get_location(mussel_id), interruptible=False)
            if self._dock(free[0], mussel_id):
                self._log("docked", mussel=mussel_id, slot=free[0])
            else:
                self._sink(mussel_id)
                self._log("skip", mussel=mussel_id, why="docking failed")
        self.status.target_mussel = 0

    def _charging_wait(self) -> None:
        self._set_phase(Phase.CHARGING_WAIT)
        self._command(self.api.hold)
        threshold = self.settings.mission.charged_threshold

        def charged() -> bool:
            return all(self._battery(m) >= threshold for m in self._docked().values())

        self._wait_until(charged)

    def _plan_redeployment(self) -> list[tuple[int, int]]:
        """Route of (slot, aMussel id) back to the original positions."""
        self._set_phase(Phase.PLAN_REDEPLOY)
        docked = self._docked()  # slot -> mussel
        ids = list(docked.values())
        position = self.api.position(self.apad_id)
        inp = PlanInput(
            apads={self.apad_id: (position.lat, position.lon)},
            capacity={self.apad_id: len(ids)},
            mussel_ids=np.array(ids, np.int64),
            lat_deg=np.array([self.homes[m].lat for m in ids]),
            lon_deg=np.array([self.homes[m].lon for m in ids]),
            battery_frac=np.array([self._battery(m) for m in ids]),
        )
        route = plan(self.settings.mission.redeploy_strategy, inp, self._weights)[self.apad_id]
        slot_of = {m: s for s, m in docked.items()}
        self.status.route = route
        self._log("plan_redeployment", strategy=self.settings.mission.redeploy_strategy, route=route)
        return [(slot_of[m], m) for m in route]

    def _redeploy(self, route: list[tuple[int, int]]) -> None:
        self._set_phase(Phase.REDEPLOY)
        for slot, mussel_id in route:
            self.status.target_mussel = mussel_id
            self._go_to(self.homes[mussel_id])
            if self._undock(slot, mussel_id):
                self._command(self.api.command_mussel, mussel_id, MusselCommand.SINK, self.apad_id)
                self._log("released", mussel=mussel_id, slot=slot)
        self.status.target_mussel = 0

    # --- primitives with waiting ------------------------------------------------------------

    def _go_to(self, target: Location, interruptible: bool = True) -> bool:
        """Go To and wait; False if the target is outside the geofence. A Go To preempted on the
        aPad (its link-loss failsafe switched to Hold) is commanded again once we hear it."""
        here = self.api.position(self.apad_id)
        self.status.cost_m += float(distance_m(here.lat, here.lon, target.lat, target.lon))
        while True:
            try:
                self._command(self.api.go_to, target, apad_id=self.apad_id)
            except GeofenceError as exc:
                self._log("geofence", what=str(exc))
                return False
            self._wait_until(lambda: self.api.goto_status(self.apad_id) != Progress.IN_PROGRESS,
                             interruptible=interruptible)
            if self.api.goto_status(self.apad_id) != Progress.FAILED:
                return True
            self._log("goto_resumed", lat=target.lat, lon=target.lon)

    def _dock(self, slot: int, mussel_id: int) -> bool:
        """Dock and wait for the latch. The slot's own report decides, not the ACK or the primitive:
        an ACK or a slot report lost on the way back, or a failsafe Hold over the dock, leave the
        latch closing; so the end is confirmed by asking the aPad for the slot."""
        try:
            self.api.docking(True, slot, mussel_id, self.apad_id)
        except CommandError as exc:
            self._log("command_failed", what=str(exc))
            if exc.result is not None:
                return False  # refused: nothing happened on the aPad

        def ours(latch: Latch) -> bool:
            s = self._slot(slot)
            return s.mussel_id == mussel_id and s.latch == latch

        def settled() -> bool:
            failed = self.api.docking_status(self.apad_id) == Progress.FAILED
            return ours(Latch.LATCHED) or (failed and not ours(Latch.CLOSING))

        # Never abandon a dock half-way: the waits ignore the end of the mission.
        self._wait_until(settled, self.settings.surfacing_timeout_s, interruptible=False)
        while True:
            try:
                s = self.api.fresh_slot(slot, self.apad_id)
            except CommandError as exc:
                self._log("command_failed", what=str(exc))
                continue
            if not (s.mussel_id == mussel_id and s.latch == Latch.CLOSING):
                return s.mussel_id == mussel_id and s.latch == Latch.LATCHED
            self._wait_until(lambda: not ours(Latch.CLOSING), self.settings.poll_s * 8, interruptible=False)

    def _undock(self, slot: int, mussel_id: int) -> bool:
        """Undock until the slot is released. A retransmitted undock is harmless: the aPad re-ACKs it,
        and it names the aMussel, so it can never release another one put in that slot since."""

        def released() -> bool:
            s = self._slot(slot)
            return s.mussel_id != mussel_id or s.latch == Latch.OPEN

        for _ in range(20):  # ~3 min; a refusal that long (e.g. not over water) leaves it on board, logged
            if released():
                return True
            if self._slot(slot).latch != Latch.RELEASING:
                try:
                    self.api.docking(False, slot, mussel_id, self.apad_id)
                except CommandError as exc:
                    self._log("command_failed", what=str(exc))
            self._wait_until(lambda: released() or self._slot(slot).latch != Latch.RELEASING,
                             timeout_s=self.settings.poll_s * 8, interruptible=False)
        if released():
            return True
        self._log("undock_failed", mussel=mussel_id, slot=slot, why="the aPad keeps refusing; it stays on board")
        return False

    def _sink(self, mussel_id: int) -> None:
        """Tell a called-up aMussel to go back down, and see that it does (the relay is not acknowledged)."""
        for _ in range(10):
            self._command(self.api.command_mussel, mussel_id, MusselCommand.SINK, self.apad_id)
            if self._wait_until(lambda: self._state(mussel_id) not in (MusselState.FLOATING, MusselState.SURFACING),
                                timeout_s=self.settings.poll_s * 8, interruptible=False):
                return
        self._log("lost", mussel=mussel_id, why="does not answer the sink command", state=self._state(mussel_id).name)

    def _command(self, fn: Callable[..., None], *args: object, **kwargs: object) -> None:
        """Run an API command; a refused one is logged and retried once the operator or time allows."""
        while True:
            try:
                fn(*args, **kwargs)
                return
            except CommandError as exc:
                self._log("command_failed", what=str(exc))
                self._sleep(self.settings.poll_s * 4)

    # --- waiting, ending, pausing -----------------------------------------------------------

    def _wait_until(self, done: Callable[[], bool], timeout_s: float | None = None, interruptible: bool = True) -> bool:
        deadline = None if timeout_s is None else self.clock.time() + timeout_s
        while not done():
            if deadline is not None and self.clock.time() >= deadline:
                return False
            self._sleep(self.settings.poll_s, interruptible)
        return True

    def _sleep(self, dt_s: float, interruptible: bool = True) -> None:
        if interruptible:
            self._check_end()
        self._wait(dt_s)
        while self.control.paused and not self.control.stop:
            self._wait(dt_s)

    def _wait(self, dt_s: float) -> None:
        hook = self.control.before_wait
        if hook is not None and hook():
            raise MissionEnded(EndReason.OPERATOR)
        self.clock.sleep(dt_s)

    def _check_end(self) -> None:
        if self.control.stop:
            raise MissionEnded(EndReason.OPERATOR)
        if self.clock.time() >= self.settings.mission.duration_s:
            raise MissionEnded(EndReason.MISSION_TIME)
        battery_v = self.api.battery_v(self.apad_id)
        if battery_v is not None and battery_v <= self.settings.battery_end_v:
            raise MissionEnded(EndReason.APAD_BATTERY)

    def _finish(self) -> None:
        """Leave the aPad holding (a dock in progress was already waited out)."""
        try:
            self.api.hold(self.apad_id)
        except CommandError as exc:
            self._log("command_failed", what=str(exc))

    # --- fleet knowledge, from what the GCS has heard ---------------------------------------

    def _candidates(self) -> list[MusselView]:
        """The charging pool: active aMussels below the pool threshold, lowest id first."""
        mussels = self.api.mussels
        ids = mussels.select((MusselState.ACTIVE,), battery_below=self.settings.mission.pool_threshold)
        return [mussels[m] for m in ids if m in self.homes]

    def _free_slots(self) -> list[int]:
        return self.api.apad(self.apad_id).free_slots()

    def _slot(self, slot: int) -> SlotView:
        return self.api.slots(self.apad_id)[slot - 1]

    def _docked(self) -> dict[int, int]:
        return {s.slot: s.mussel_id for s in self.api.slots(self.apad_id) if s.latch == Latch.LATCHED}

    def _state(self, mussel_id: int) -> MusselState:
        return self.api.mussels[mussel_id].state

    def _battery(self, mussel_id: int) -> float:
        return self.api.mussels[mussel_id].battery_frac

    def _distance_to(self, mussel_id: int) -> float:
        here, there = self.api.position(self.apad_id), self.api.get_location(mussel_id)
        return float(distance_m(here.lat, here.lon, there.lat, there.lon))

    def _too_late_to_call_up(self) -> bool:
        return self.settings.mission.duration_s - self.clock.time() < self.settings.call_up_margin_s

    def _call_up_if_in_range(self, mussel_id: int) -> bool:
        """Safety: an aMussel is only called to the surface with an aPad within acoustic range."""
        distance = self._distance_to(mussel_id)
        if distance > self.settings.acoustic_range_m:
            return False
        self._command(self.api.command_mussel, mussel_id, MusselCommand.SURFACE, self.apad_id)
        self._log("call_up", mussel=mussel_id, distance_m=round(distance, 2))
        return True

    def _take_strategy_switch(self) -> None:
        with self.control.lock:
            new, self.control.strategy = self.control.strategy, None
        if new and new != self.status.strategy:
            self._log("strategy_switch", old=self.status.strategy, new=new)
            self.status.strategy = new

    def _set_phase(self, phase: Phase) -> None:
        if phase != self.status.phase or phase == Phase.IDLE_WAIT:
            self.status.phase = phase
            self._log("phase", phase=str(phase))

    def _log(self, kind: str, **fields: object) -> None:
        self.events.emit(self.clock.time(), kind, **fields)
