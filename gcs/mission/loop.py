"""The energy-sharing scenario loop (the paper's Fig. 7), written on the aPad API.

Idle wait -> plan collection -> collect (go to, call up, dock) x up to 4 -> charging wait ->
plan redeployment -> redeploy (go to the original position, undock, sink) -> idle wait ...

It commands the aPad exactly as a field script would, waiting with `clock.sleep`, so the same
code runs in lockstep and in the field. The operator (console or script) controls it through
`LoopControl`: pause, stop, strategy switch. The mission ends on mission time, on the aPad
battery threshold, or on an operator stop; it never ends mid-dock.
"""

from __future__ import annotations

import functools

import numpy as np

from apad_sitl.vocabulary import Latch
from gcs.mission.accounting import SURFACE_DEPTH_M
from gcs.mission.actions import LoopActions
from gcs.mission.control import EndReason, LoopControl, LoopSettings, MissionEnded, Phase
from gcs.mission.rolling_loop import charged, outlook, rolling_round
from gcs.mission.strategies import CollectStrategy, CostWeights, PlanInput, plan, traits
from mussel_sim.vocabulary import MusselCommand, MusselState

RESHARED = "another aPad's since the fleet was re-shared"
REPLAN_S = 10.0

__all__ = ["EndReason", "EnergySharingLoop", "LoopControl", "LoopSettings", "MissionEnded", "Phase"]


class EnergySharingLoop(LoopActions):
    """The paper's Fig. 7 over `LoopActions`: idle wait, plan, collect, charge, redeploy, again."""

    @property
    def _weights(self) -> CostWeights:
        return CostWeights(self.settings.mission.distance_scale, self.settings.mission.energy_scale)

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
                if traits(self.status.strategy).rolling:
                    rolling_round(self)  # the rolling policy's own turn (gcs.mission.rolling_loop)
                    continue
                self._idle_wait()
                route = self._plan_collection()
                if route:
                    self._collect(route)
                elif not self._docked():  # the strategy takes none of the pool yet: look again later
                    self._set_phase(Phase.IDLE_WAIT)
                    self._sleep(REPLAN_S)
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
        if not self._wait_until(lambda: not any(s.latch in (Latch.CLOSING, Latch.RELEASING)
                                                for s in self.api.slots(self.apad_id)),
                                self.settings.surfacing_timeout_s, interruptible=False):
            self._log("gave_up", what="waiting for latches in motion", slots=[
                s.slot for s in self.api.slots(self.apad_id) if s.latch in (Latch.CLOSING, Latch.RELEASING)])
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
            if self.status.strategy == CollectStrategy.NONE or self._too_late_to_call_up():
                return False
            if self._orphans() and self._free_slots() and self._link_up():
                return True  # left floating by a lost aPad: fetch them now
            need = min(mission.min_pool, len(self._free_slots()))
            return need > 0 and len(self._candidates()) >= need and self._link_up()

        self._wait_until(pool_full)

    def _plan_collection(self) -> list[int]:
        self._set_phase(Phase.PLAN_COLLECT)
        self._take_strategy_switch()
        orphaned = self._orphans()[:len(self._free_slots())]
        route = orphaned + self._collection_route(len(orphaned))
        if route or self.status.route:  # one event for a run of empty plans (a strategy waiting)
            self._log("plan_collection", strategy=self.status.strategy, route=route,
                      **({"orphans": orphaned} if orphaned else {}))
        self.status.route = route
        return route

    def _collection_route(self, reserved: int = 0) -> list[int]:
        """The strategy's route over the charging pool for the free slots but `reserved`."""
        inp = self._collection_input(self._candidates(), len(self._free_slots()) - reserved)
        return plan(self.status.strategy, inp, self._weights)[self.apad_id]

    def _collection_input(self, ids: list[int], capacity: int) -> PlanInput:
        """A planning step over these aMussels where they are now, from where the aPad is now."""
        views = [self.api.mussels[m] for m in ids]
        position = self.api.position(self.apad_id)
        return PlanInput(
            apads={self.apad_id: (position.lat, position.lon)},
            capacity={self.apad_id: capacity},
            mussel_ids=np.array(ids, np.int64),
            lat_deg=np.array([m.location.lat for m in views]),
            lon_deg=np.array([m.location.lon for m in views]),
            battery_frac=np.array([self._battery(m) for m in ids]),
            outlook=outlook(self.settings, self.clock.time()),
        )

    def _collect(self, route: list[int]) -> None:
        self._set_phase(Phase.COLLECT)
        route = list(route)
        while route:
            self._check_end()  # between aMussels nothing is half done: an operator stop ends here
            self._wait_for_link()  # and nothing is lost by waiting here as long as the mission lasts
            route = self._recheck_route(route)
            if not route:
                break
            mussel_id = route.pop(0)
            free = self._free_slots()
            if not free:
                break
            if self._too_late_to_call_up():
                self._log("skip", mussel=mussel_id, why="too close to the mission end to dock it")
                break
            self.status.target_mussel = mussel_id
            if not self._serves(mussel_id):
                self._log("skip", mussel=mussel_id, why=RESHARED)
                continue
            called = self._call_up_if_in_range(mussel_id)
            # From a call-up on, the waits ignore the mission end: the margin above leaves time to finish.
            if not self._go_to(self.api.get_location(mussel_id), interruptible=not called):
                if called:
                    self._sink(mussel_id)
                continue
            if not called and not self._call_up_if_in_range(mussel_id):
                self._log("skip", mussel=mussel_id,
                          why=RESHARED if not self._serves(mussel_id) else "no aPad within acoustic range")
                continue
            if not self._wait_until(functools.partial(self._floating_or_depleted, mussel_id),
                                    self.settings.surfacing_timeout_s, interruptible=False):
                if self._taken_over(mussel_id):
                    continue
                self._log("skip", mussel=mussel_id, why="did not surface", state=self._state(mussel_id).name)
                self._sink(mussel_id)  # it may surface later: it must not float there forever
                continue
            if self._state(mussel_id) == MusselState.DEPLETED:  # no use waiting it out: it cannot move now
                self._release(mussel_id)
                at_surface = self.api.mussels[mussel_id].depth_m <= SURFACE_DEPTH_M
                self._log("skipped", mussel=mussel_id,
                          why="depleted at the surface" if at_surface else "depleted before it floated")
                continue
            # It surfaced where it was last localised underwater, give or take drift: close in.
            if self._taken_over(mussel_id):
                continue
            if self._distance_to(mussel_id) > 0.8 * self.settings.dock_reach_m:
                self._go_to(self.api.get_location(mussel_id), interruptible=False)
            if self._taken_over(mussel_id):
                continue
            if self._dock(free[0], mussel_id):
                self._log("docked", mussel=mussel_id, slot=free[0])
                self.status.dockings.append((self.clock.time(), mussel_id))
            else:
                self._sink(mussel_id)
                self._log("skip", mussel=mussel_id, why="docking failed")
        self.status.target_mussel = 0

    def _recheck_route(self, route: list[int]) -> list[int]:
        """Before each leg: drop every aMussel of the route that can no longer be collected (a
        `skipped` event with the reason: depleted meanwhile, or its battery would give out before it
        floats), and if any was dropped plan the order of the rest again, from here, with the
        strategy (those already floating first, as planned)."""
        keep = []
        for mussel_id in route:
            why = self._cannot_collect(mussel_id)
            if why is None:
                keep.append(mussel_id)
            else:
                self._log("skipped", mussel=mussel_id, why=why)
        if len(keep) == len(route):
            return route
        floating = [m for m in keep if self._floating(m)]
        rest = [m for m in keep if m not in floating]
        inp = self._collection_input(rest, len(rest))
        new = floating + plan(self.status.strategy, inp, self._weights)[self.apad_id] if rest else floating
        if sorted(new) != sorted(keep):  # a strategy that would not take them all: keep the planned order
            new = keep
        self.status.route = new
        self._log("replan_collection", strategy=self.status.strategy, route=new)
        return new

    def _floating_or_depleted(self, mussel_id: int) -> bool:
        return self._state(mussel_id) in (MusselState.FLOATING, MusselState.DEPLETED)

    def _charging_wait(self) -> None:
        self._set_phase(Phase.CHARGING_WAIT)
        self._command(self.api.hold)
        self._wait_until(lambda: all(charged(self, m) for m in self._docked().values()))

    def _plan_redeployment(self, only: set[int] | None = None) -> list[tuple[int, int]]:
        """Route of (slot, aMussel id) back to the original positions (of those docked, or of `only`)."""
        self._set_phase(Phase.PLAN_REDEPLOY)
        docked = {s: m for s, m in self._docked().items() if only is None or m in only}  # slot -> mussel
        ids = list(docked.values())
        for m in ids:
            self._note_home(m)  # one docked with no home known (e.g. held since a crash): back to here
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
        self._leaving.clear()
        for slot, mussel_id in route:
            self._check_end()  # between legs: no trip starts after the end (the rest stay on their slots)
            self.status.target_mussel = mussel_id
            self._wait_for_link()
            if not self._go_to(self.homes[mussel_id]):
                self._log("kept_on_board", mussel=mussel_id, slot=slot, why="its position could not be reached")
                continue
            if self._undock(slot, mussel_id):
                if self.api.mussels[mussel_id].simulated:  # a local party: the command cannot be lost
                    self._command(self.api.command_mussel, mussel_id, MusselCommand.SINK, self.apad_id)
                    self._release(mussel_id)
                    self._leaving.add(mussel_id)  # not waited for here: the next leg gives it time
                else:
                    self._sink(mussel_id)  # over a radio: seen to leave the surface (releases the claim)
                self._log("released", mussel=mussel_id, slot=slot)
        self.status.target_mussel = 0

    def _take_strategy_switch(self) -> None:
        with self.control.lock:
            new, self.control.strategy = self.control.strategy, None
        if new and new != self.status.strategy:
            self._log("strategy_switch", old=self.status.strategy, new=new)
            self.status.strategy = new
