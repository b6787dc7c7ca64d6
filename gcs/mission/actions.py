"""The aPad actions the energy-sharing loop is written in: each command with its wait.

Go To, Dock, Undock and Sink each command the aPad through the API and wait, on the clock, until
the aPad or the fleet reports the result; every wait is bounded or interruptible, and the mission
ends only between actions (never mid-dock). The loop's phases (`gcs.mission.loop`) build on these.
"""

from __future__ import annotations

from collections.abc import Callable

from apad_sitl.vocabulary import Latch, Progress
from gcs.api import ApadApi, CommandError, GeofenceError, Location
from gcs.link.telemetry import SlotView
from gcs.mission.control import EndReason, LoopControl, LoopSettings, LoopStatus, MissionEnded, Phase
from gcs.records.events import EventLog
from missiontime import Clock
from mussel_sim.geo import distance_m
from mussel_sim.vocabulary import MusselCommand, MusselState


class LoopActions:
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

    def _candidates(self) -> list[int]:
        """The charging pool: ids of active aMussels below the pool threshold, lowest first."""
        ids = self.api.mussels.select((MusselState.ACTIVE,), battery_below=self.settings.mission.pool_threshold)
        return [m for m in ids if m in self.homes]

    def _free_slots(self) -> list[int]:
        return self.api.apad(self.apad_id).free_slots()

    def _slot(self, slot: int) -> SlotView:
        return self.api.slots(self.apad_id)[slot - 1]

    def _docked(self) -> dict[int, int]:
        return {s.slot: s.mussel_id for s in self.api.slots(self.apad_id) if s.latch == Latch.LATCHED}

    def _floating(self, mussel_id: int) -> bool:
        return self._state(mussel_id) == MusselState.FLOATING

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

    def _set_phase(self, phase: Phase) -> None:
        if phase != self.status.phase or phase == Phase.IDLE_WAIT:
            self.status.phase = phase
            self._log("phase", phase=str(phase))

    def _log(self, kind: str, **fields: object) -> None:
        self.events.emit(self.clock.time(), kind, **fields)
