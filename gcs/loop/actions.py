"""The aPad's actions the energy-sharing loop is written in: each command with its wait.

Go To, Dock, Undock and Sink each command the aPad through the API and wait, on the clock, until
the aPad or the fleet reports the result; every wait is bounded or interruptible, and the mission
ends only between actions (never mid-dock). `ApadActions` reads the fleet through
`FleetKnowledge` (`gcs.loop.fleet_knowledge`), keeps the loop's `LoopStatus` (phase, cost) and
follows the operator's `LoopControl`; the loop's phases (`gcs.loop.phases`) are built on it.
"""

from __future__ import annotations

from collections.abc import Callable
from enum import Enum, auto
from functools import partial

from apad_sitl.vocabulary import Latch, Progress
from gcs.acoustic_net.call_ups import CallUp
from gcs.belief.duty import Duty
from gcs.link.apad_api import CommandError, GeofenceError, Location
from gcs.loop import wait_check
from gcs.loop.control import EndReason, LoopControl, LoopLog, LoopStatus, MissionEnded, Phase
from gcs.loop.fleet_knowledge import READS_ALL, FleetKnowledge, Reads
from gcs.loop.telemetry_pace import HOLDING_PHASES, PACE_WORTH_S, PLANNING_PHASES, TelemetryPace
from gcs.swarm.shares import others_lapse_s, route_conflicts
from missiontime import us_to_s
from missiontime.clocks import Declared
from mussel_sim.geo import pair_distance_m
from mussel_sim.vocabulary import MusselCommand, MusselState

# A Go To not reported done by GOTO_SLACK_S + GOTO_SLOWNESS x the trip at the aPad's speed is sent again.
GOTO_SLACK_S = 60.0
GOTO_SLOWNESS = 3.0
GOTO_HEARD_S = 5.0  # the aPad reports its primitive every second; five lost in a row is rare even at 40 % loss


class _Looked(Enum):
    """What a wait's look after a sleep found (`ApadActions.wait_until`)."""

    DONE = auto()
    TIMED_OUT = auto()
    YOURS = auto()  # paused, or the console's hook set: the script's own thread takes the wait on


class ApadActions:
    """One aPad's commands with their waits, over what its loop knows of the fleet. `leaving` holds
    the aMussels let go in the current redeployment and not yet seen off their slots (`finish`)."""

    def __init__(self, knows: FleetKnowledge, control: LoopControl, status: LoopStatus, log: LoopLog) -> None:
        self.knows = knows
        self.api = knows.api
        self.clock = knows.clock
        self.settings = knows.settings
        self.apad_id = knows.apad_id
        self.control = control
        self.status = status
        self.leaving: set[int] = set()
        self._log = log
        self._phase_since_s = self.clock.time()
        self.pace = TelemetryPace(self.api, self.apad_id, log)  # slow telemetry while it holds, fast while it moves

    # --- primitives with waiting ------------------------------------------------------------

    def go_to(self, target: Location, interruptible: bool = True) -> bool:
        """Go To and wait; False if it cannot be done (outside the geofence, or the bounds below hit).

        A Go To preempted on the aPad (its link-loss failsafe switched to Hold) is commanded again
        once we hear it; one that takes far longer than the trip should is commanded again too.
        At most `goto_attempts` commands, then the loop gives up on this target (an event)."""
        self._moving()
        here = self.api.position(self.apad_id)
        distance = pair_distance_m(here.lat, here.lon, target.lat, target.lon)
        self.status.cost_m += distance
        trip_limit_s = GOTO_SLACK_S + GOTO_SLOWNESS * distance / self.settings.apad_speed_mps
        if self.knows.shares is not None and self.api.inside_geofence(target):
            self._keep_apart(target, interruptible)
        for _ in range(self.settings.goto_attempts):
            try:
                self.api.go_to(target, apad_id=self.apad_id)
            except GeofenceError as exc:
                self._log("geofence", what=str(exc))
                return False
            except CommandError as exc:
                self._log("command_failed", what=str(exc))
                self.sleep(self.settings.poll_s * 4, interruptible)
                continue
            mine = self.api.apad(self.apad_id).expected
            # Accepted, but not one report on it (all lost, or the failsafe took over unheard):
            # send it again; a re-send of a Go To in force is answered, not restarted.
            if not self.wait_until(partial(self._goto_heard, mine), timeout_s=GOTO_HEARD_S,
                                    interruptible=interruptible, reads=Reads.OWN):
                self._log("goto_unconfirmed", lat=target.lat, lon=target.lon, after_s=GOTO_HEARD_S)
                continue
            if not self.wait_until(partial(self._goto_over, mine), timeout_s=trip_limit_s,
                                    interruptible=interruptible, reads=Reads.OWN):
                self._log("goto_timeout", lat=target.lat, lon=target.lon, after_s=round(trip_limit_s, 1))
                continue
            if self._replaced(mine):  # the operator commanded the aPad meanwhile: the loop takes it back
                self._log("goto_resent", lat=target.lat, lon=target.lon, why="the operator commanded the aPad")
                continue
            if self.api.goto_status(self.apad_id) != Progress.FAILED:
                return True
            self._log("goto_resumed", lat=target.lat, lon=target.lon)
        self._log("gave_up", what="go to", lat=target.lat, lon=target.lon, attempts=self.settings.goto_attempts)
        return False

    def _replaced(self, mine: object) -> bool:
        """Whether another command (the operator's) replaced the primitive this loop commanded."""
        return self.api.apad(self.apad_id).expected is not mine

    def _goto_heard(self, mine: object) -> bool:
        return self.api.primitive_heard(self.apad_id) or self._replaced(mine)

    def _goto_over(self, mine: object) -> bool:
        return self.api.goto_status(self.apad_id) != Progress.IN_PROGRESS or self._replaced(mine)

    def _keep_apart(self, target: Location, interruptible: bool) -> None:
        """Several aPads: do not set off while the straight leg to `target` passes within
        `separation_m` of another aPad or of where it is going. Wait for the way to clear, at most
        `separation_wait_s`, then go anyway (an event says so: e.g. another aPad charging there)."""
        def blocked() -> list[int]:
            return route_conflicts(self.api, self.apad_id, target, self.settings.separation_m)

        if not blocked():
            return
        self._log("separation_wait", lat=target.lat, lon=target.lon, apads=blocked())
        if not self.wait_until(lambda: not blocked(), self.settings.separation_wait_s, interruptible,
                               look_by=partial(others_lapse_s, self.api, self.apad_id)):
            self._log("separation_wait_expired", lat=target.lat, lon=target.lon, apads=blocked())

    def dock(self, slot: int, mussel_id: int) -> bool:
        """Dock and wait for the latch. The slot's own report decides, not the ACK or the primitive:
        an ACK or a slot report lost on the way back, or a failsafe Hold over the dock, leave the
        latch closing; so the end is confirmed by asking the aPad for the slot."""
        self._moving()
        try:
            self.api.docking(True, slot, mussel_id, self.apad_id)
        except CommandError as exc:
            self._log("command_failed", what=str(exc))
            if exc.result is not None:
                return False  # refused: nothing happened on the aPad

        def ours(latch: Latch) -> bool:
            s = self.knows.slot(slot)
            return s.mussel_id == mussel_id and s.latch == latch

        mine = self.api.apad(self.apad_id).expected

        def settled() -> bool:  # an operator's command over the dock: its latch decides alone
            failed = self.api.docking_status(self.apad_id) == Progress.FAILED or self._replaced(mine)
            return ours(Latch.LATCHED) or (failed and not ours(Latch.CLOSING))

        # Never abandon a dock half-way: the waits ignore the end of the mission.
        self.wait_until(settled, self.settings.surfacing_timeout_s, interruptible=False, reads=Reads.OWN)
        for _ in range(self.settings.command_attempts * 4):  # a latch closes in seconds: this is minutes
            try:
                s = self.api.fresh_slot(slot, self.apad_id)
            except CommandError as exc:
                self._log("command_failed", what=str(exc))
                continue
            if not (s.mussel_id == mussel_id and s.latch == Latch.CLOSING):
                return s.mussel_id == mussel_id and s.latch == Latch.LATCHED
            self.wait_until(lambda: not ours(Latch.CLOSING), self.settings.poll_s * 8, interruptible=False,
                            reads=Reads.OWN)
        self._log("gave_up", what="dock confirmation", mussel=mussel_id, slot=slot)
        return ours(Latch.LATCHED)

    def undock(self, slot: int, mussel_id: int) -> bool:
        """Undock until the slot is released. A retransmitted undock is harmless: the aPad re-ACKs it,
        and it names the aMussel, so it can never release another one put in that slot since."""

        def released() -> bool:
            s = self.knows.slot(slot)
            return s.mussel_id != mussel_id or s.latch == Latch.OPEN

        for _ in range(20):  # ~3 min; a refusal that long (e.g. not over water) leaves it on board, logged
            if released():
                return True
            if self.knows.slot(slot).latch != Latch.RELEASING:
                try:
                    self.api.docking(False, slot, mussel_id, self.apad_id)
                except CommandError as exc:
                    self._log("command_failed", what=str(exc))
            self.wait_until(lambda: released() or self.knows.slot(slot).latch != Latch.RELEASING,
                             timeout_s=self.settings.poll_s * 8, interruptible=False, reads=Reads.OWN)
        if released():
            return True
        self._log("undock_failed", mussel=mussel_id, slot=slot, why="the aPad keeps refusing; it stays on board")
        return False

    def sink(self, mussel_id: int) -> None:
        """Tell a called-up aMussel to go back down, and see that it does (the relay is not acknowledged);
        one that does not answer is logged `lost` (floating: an orphan its owner will come back for)."""
        for _ in range(10):
            self.command(self.api.command_mussel, mussel_id, MusselCommand.SINK, self.apad_id)
            if self.wait_until(lambda: self.knows.state(mussel_id) not in (MusselState.FLOATING, MusselState.SURFACING),
                                timeout_s=self.settings.poll_s * 8, interruptible=False):
                return
        self._log("lost", mussel=mussel_id, why="does not answer the sink command",
                  state=self.knows.state(mussel_id).name)

    def hold(self) -> bool:
        """Hold position here (a command to this loop's aPad: False at its bound, logged)."""
        return self.command(self.api.hold, self.apad_id)

    def tell_to_sink(self, mussel_id: int) -> bool:
        """Tell an aMussel to go down, not waiting to see it leave (a simulated one, a local party: the
        command cannot be lost; `sink` sees one over a radio off the surface)."""
        return self.command(self.api.command_mussel, mussel_id, MusselCommand.SINK, self.apad_id)

    def sleep_order(self, mussel_id: int, duty: Duty) -> bool:
        """Send the aMussel a sleep order (its wake interval and awake time) through the aPad."""
        return self.command(self.api.sleep_order, mussel_id, duty.interval_s, duty.awake_s, self.apad_id)

    def slow_telemetry(self) -> None:
        """Slow telemetry while it holds for long (hours at the charger); fast again at the next move."""
        self.pace.hold()

    def command(self, fn: Callable[..., None], *args: object, **kwargs: object) -> bool:
        """Run an API command; a refused or unanswered one is logged and tried again, at most
        `command_attempts` times (each is itself several sends: `gcs.link.command_protocol`). False at the
        bound, with a `gave_up` event: the caller leaves that step for now and goes on."""
        for _ in range(self.settings.command_attempts):
            try:
                fn(*args, **kwargs)
                return True
            except CommandError as exc:
                self._log("command_failed", what=str(exc))
                self.sleep(self.settings.poll_s * 4)
        self._log("gave_up", what=getattr(fn, "__name__", str(fn)), attempts=self.settings.command_attempts)
        return False

    # --- the link -----------------------------------------------------------------------------

    def link_up(self) -> bool:
        return self.knows.link_up()

    def wait_for_link(self, timeout_s: float | None = None, interruptible: bool = True) -> bool:
        """Wait until the aPad is heard again (events `link_lost`, `link_back`); False at the bound."""
        if self.link_up():
            return True
        silent_us = self.api.link.registry.silent_us(self.api.apad(self.apad_id), self.clock.now_us)
        self._log("link_lost", silent_s=round(us_to_s(silent_us), 1))
        if self.wait_until(self.link_up, timeout_s, interruptible):
            self._log("link_back")
            return True
        self._log("gave_up", what="waiting for the aPad's link", after_s=timeout_s)
        return False

    # --- waiting, ending, pausing -----------------------------------------------------------

    def wait_until(self, done: Callable[[], bool], timeout_s: float | None = None, interruptible: bool = True,
                   holding_for_s: float = 0.0, look_by: Callable[[], float | None] | None = None,
                   reads: Reads = READS_ALL) -> bool:
        """Wait until `done`; False at `timeout_s`. What it waits for is declared: `done` reads what the GCS
        knows, so news (a report, an acknowledgement) can turn it true, and time alone from `look_by()` on
        (the first instant, mission s, a belief running between reports could: `gcs.loop.wake_times`;
        None: only news can). Lockstep and the field look at every `poll_s`, as a field script's sleep loop
        does (the reference); a platform that jumps from event to event wakes at news or `look_by`
        instead, and `gcs.loop.wait_check` holds the declarations to what lockstep sees. `reads`: what `done`
        reads that only a message changes (`FleetKnowledge.news`); news of anything else does not wake it.
        With slow telemetry in a holding phase, or when it holds in place for about `holding_for_s` (above
        an aMussel on its way up) and that is worth two rounds of requests (`PACE_WORTH_S`)."""
        news = self.knows.news if reads == READS_ALL else partial(self.knows.news, reads)
        if wait_check.ENABLED:
            check = wait_check.WaitCheck(news, self.clock, look_by, getattr(done, "__qualname__", "wait"))
            done = partial(check.looked, done)
        deadline = None if timeout_s is None else self.clock.time() + timeout_s
        holding = holding_for_s > PACE_WORTH_S or self.status.phase in HOLDING_PHASES
        if holding and self.link_up() and not done():
            self.pace.hold()  # it holds in place until `done`: slow telemetry meanwhile
        poll_s = self.settings.poll_s

        def settled() -> _Looked | None:  # the loop's head: done, the deadline, the mission's end
            if done():
                return _Looked.DONE
            if deadline is not None and self.clock.time() >= deadline:
                return _Looked.TIMED_OUT
            if interruptible:
                self.check_end()
            return None

        def look() -> _Looked | None:  # after each sleep: a pause or the console's hook is the script's own
            if (self.control.paused and not self.control.stop) or self.control.before_wait is not None:
                return _Looked.YOURS
            return settled()

        def wake_at() -> float | None:  # the first instant time alone could settle it (an event platform's look)
            times = [t for t in (look_by() if look_by is not None else None, deadline,
                                 self.settings.mission.duration_s if interruptible else None) if t is not None]
            return min(times) if times else None

        declared = Declared(wake_at, news)

        while (looked := settled()) is None:
            if self.control.before_wait is not None:  # the console's hook sees every sleep
                self._wait(poll_s)
            elif (looked := self.clock.sleep_until(look, poll_s, declared)) is not _Looked.YOURS:
                break
            while self.control.paused and not self.control.stop:
                self._wait(poll_s)
        return looked is _Looked.DONE

    def _moving(self) -> None:
        """Fast telemetry again before a command that moves the aPad (after a holding wait in a phase)."""
        if self.pace.holding and self.link_up():  # a silent aPad would not answer: asked at the next change
            self.pace.move()

    def hold_for(self, dt_s: float) -> None:
        """Wait `dt_s` holding in place (a strategy that takes nobody yet): slow telemetry meanwhile."""
        if self.status.phase in HOLDING_PHASES and self.link_up():
            self.pace.hold()
        self.sleep(dt_s)

    def sleep(self, dt_s: float, interruptible: bool = True) -> None:
        if interruptible:
            self.check_end()
        self._wait(dt_s)
        while self.control.paused and not self.control.stop:
            self._wait(dt_s)

    def _wait(self, dt_s: float) -> None:
        hook = self.control.before_wait
        if hook is not None and hook():
            raise MissionEnded(EndReason.OPERATOR)
        self.clock.sleep(dt_s)

    def check_end(self) -> None:
        if self.control.stop:
            raise MissionEnded(EndReason.OPERATOR)
        if self.clock.time() >= self.settings.mission.duration_s:
            raise MissionEnded(EndReason.MISSION_TIME)
        battery_v = self.api.battery_v(self.apad_id)
        if battery_v is not None and battery_v <= self.settings.battery_end_v:
            raise MissionEnded(EndReason.APAD_BATTERY)

    def begin_redeployment(self) -> None:
        """A redeployment starts: none of its aMussels let go yet."""
        self.leaving.clear()

    def let_go(self, mussel_id: int) -> None:
        """An aMussel released and told to sink: `finish` sees it off its slot."""
        self.leaving.add(mussel_id)

    def finish(self) -> None:
        """Leave the aPad holding (a dock in progress was already waited out), and see every aMussel
        this redeployment let go reported off its slot: the simulated fleet applies a release at its
        next step, so one whose latch report it heard only in the last instant (e.g. the RELEASING
        report lost, the OPEN one heard by the fleet and the GCS at once) would end docked on an open
        slot. Bounded; at the bound a `gave_up` event names them (the account reports them lost)."""
        try:
            self.api.hold(self.apad_id)
        except CommandError as exc:
            self._log("command_failed", what=str(exc))

        def still_docked() -> list[int]:
            return sorted(m for m in self.leaving if self.knows.state(m) == MusselState.DOCKED)

        if not self.wait_until(lambda: not still_docked(), self.settings.surfacing_timeout_s, interruptible=False):
            self._log("gave_up", what="seeing released aMussels leave their slots", mussels=still_docked())

    # --- calling up, the phase record -------------------------------------------------------

    def call_up_if_in_range(self, mussel_id: int) -> bool:
        """Safety: an aMussel is only called to the surface with an aPad within acoustic range (with several
        aPads the phase has claimed it first: `phases.call_up`). False: not called."""
        if self.knows.state(mussel_id) == MusselState.FLOATING:
            return True  # already up (an orphan): nothing to call
        distance = self.knows.distance_to(mussel_id)
        if distance > self.settings.acoustic_range_m:
            return False
        acoustic = self.knows.acoustic
        if acoustic is None:
            self.command(self.api.command_mussel, mussel_id, MusselCommand.SURFACE, self.apad_id)
            self._log("call_up", mussel=mussel_id, distance_m=round(distance, 2))
        else:  # over the water, acknowledged, retried; a sleeper pinged awake first
            outcome = acoustic.call_ups.call_up(mussel_id, partial(self.knows.asleep, mussel_id), self.apad_id,
                                              self._wait, wanted=partial(self.knows.heard_alive, mussel_id))
            if outcome is CallUp.ABANDONED:  # believed empty before a call-up went: not called
                return False
            self._log("call_up", mussel=mussel_id, distance_m=round(distance, 2), acoustic=True,
                      acked=outcome is CallUp.ACKED)
        return True

    def set_phase(self, phase: Phase) -> None:
        if phase != self.status.phase or phase == Phase.IDLE_WAIT:
            now = self.clock.time()
            spent = self.status.phase_s
            spent[self.status.phase] = spent.get(self.status.phase, 0.0) + now - self._phase_since_s
            self._phase_since_s = now
            self.status.phase = phase
            self._log("phase", phase=str(phase))
        if phase not in HOLDING_PHASES | PLANNING_PHASES and self.link_up():  # a silent aPad: asked at the next change
            self.pace.move()  # fast telemetry from the first command of a phase that acts
