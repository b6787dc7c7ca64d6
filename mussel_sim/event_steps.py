"""The fleet runner on the event platform: one step task, rescheduled to where something changes.

Lockstep steps the model every period and publishes every second. Here the one task `mussel-step`
steps it at the instants of lockstep's step grid (`event_grid.EventGrid`) where something changes and
nowhere else, each step covering the periods since the last at once (`fleet.step` is exact over them:
`next_change`), and publishes the statuses right after each step, by exception with no keep-alive
(the same rules and send path as lockstep's, so the GCS gets the same objects). The next step is
rescheduled after each one: at the end of what the model may take at once, the recorder's day's end,
the mission's last step; an input (a command, a sleep order, a slot's report, a wake-up ping) brings it
forward to the first step instant after it. An aPad's position is not an input: an aMussel riding on it
(docked) follows it at the model's next step, not each second (docs/platforms.md).

Before an input is queued the model is brought to lockstep's last step instant (`catch_up`, a step with
no input): the input's own step then covers one period with the queued inputs, as lockstep's does (a
sleeper's call-up is held or not by whether it is awake in that period; a ping's listening time counts
from that step; the release status the charger meters by shows that step's battery).
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from mavlink_dialect import mavlink
from missiontime import Scheduler, Task, seconds_to_us
from mussel_sim.apad_fixes import ApadFixes
from mussel_sim.comms_config import CommsConfig
from mussel_sim.event_grid import EventGrid
from mussel_sim.fleet_orders import PendingOrders
from mussel_sim.fleet_state import FleetInputs, FleetParams, FleetState
from mussel_sim.geo import LocalFrame
from mussel_sim.keepalive_positions import KeepAlivePositions
from mussel_sim.next_change import steps_at_once
from mussel_sim.recorder import Recorder


class FleetRunner(Protocol):
    """What the stepper uses of its runner (`mussel_sim.comms.FleetRunner`, which makes it)."""

    state: FleetState
    params: FleetParams
    rng: np.random.Generator
    config: CommsConfig
    frame: LocalFrame
    recorder: Recorder
    apads: ApadFixes
    orders: PendingOrders

    def step_task(self, now_us: int) -> None: ...

    def step_to(self, now_us: int, inputs: FleetInputs, periods: int = 1) -> None: ...

    def publish_status_task(self, now_us: int) -> None: ...

    def quiet_inputs(self, step_us: int | None = None) -> FleetInputs: ...

    def take_inputs(self, step_us: int | None = None) -> FleetInputs: ...

# Messages that queue something for the next step (or, a slot's report, ask the charger's report of it).
_INPUTS = (mavlink.MAVLink_dock_slot_status_message, mavlink.MAVLink_amussel_command_message,
           mavlink.MAVLink_amussel_sleep_order_message)


class EventSteps:
    """The step task of a `FleetRunner` on the event platform (made by `FleetRunner.register(events=True)`)."""

    def __init__(self, runner: FleetRunner, scheduler: Scheduler, grid: EventGrid) -> None:
        self.runner = runner
        cfg = runner.config  # the positions lockstep's keep-alive would have told the GCS:
        self.keepalive = KeepAlivePositions(runner.state.n, seconds_to_us(cfg.status_keepalive_s), grid.period_us,
                                            runner.frame, cfg.wifi_at_surface_only)
        self.scheduler = scheduler
        self.grid = grid
        self._coming = False  # the message acting now is an input (`input_coming`)
        self.steps = 0  # model steps taken (the event platform's cost, against lockstep's one a period)
        # First at the start: the statuses of the start state, as lockstep's first publish.
        self.task: Task = scheduler.every(grid.period_us / 1e6, self.run, "mussel-step", grid.origin_us)

    @property
    def step_s(self) -> float:
        return self.grid.period_us / 1e6

    def run(self, now_us: int) -> None:
        """The task: step to `now_us` (a step instant), publish, and reschedule the next step."""
        r = self.runner
        if now_us > r.state.time_us:
            if now_us > self.grid.last_us():  # past the mission's last step: latches only, as lockstep
                r.step_task(now_us)
            else:
                period = self.grid.period_us
                if r.orders.pending and now_us - r.state.time_us > period:
                    self._quiet_step(now_us - period)  # the inputs' step is one period, as lockstep's
                self.steps += 1
                self.keepalive.before_step(r.state, now_us, r.rng, r.params)
                r.step_to(now_us, r.take_inputs(now_us), (now_us - r.state.time_us) // period)
        r.publish_status_task(now_us)
        self._schedule()

    def _quiet_step(self, to_us: int) -> None:
        r = self.runner
        self.steps += 1
        self.keepalive.before_step(r.state, to_us, r.rng, r.params)
        r.step_to(to_us, r.quiet_inputs(to_us), (to_us - r.state.time_us) // self.grid.period_us)
        r.publish_status_task(to_us)

    def _schedule(self) -> None:
        r = self.runner
        at_once = steps_at_once(r.state, r.params, self.step_s)
        nxt = self.grid.next_step_us(r.state.time_us, at_once, r.recorder.days)
        if nxt is None:
            self.scheduler.reschedule(self.task, active=False)
        else:
            self.scheduler.reschedule(self.task, next_us=nxt, active=True)

    def resumed(self) -> None:
        """The runner's state was replaced by a saved one (a resumed mission): the grid from its time on."""
        self.grid = EventGrid(self.runner.state.time_us, self.grid.period_us, self.grid.end_us)
        self._schedule()

    def catch_up(self, now_us: int) -> None:
        """Step the model, with no input, to lockstep's last step instant at `now_us` (never past the
        next step scheduled: nothing discontinuous lies before it)."""
        r = self.runner
        to_us = self.grid.floor_us(now_us)
        if self.task.active:
            to_us = min(to_us, self.task.next_us - self.grid.period_us)
        if to_us > r.state.time_us:
            self._quiet_step(to_us)

    def refresh_positions(self, now_us: int) -> None:
        """The GCS reads the aMussels' positions: hand it what lockstep's keep-alive would have by now."""
        r = self.runner
        self.keepalive.refresh(now_us, r.state, r.rng, r.params)

    @staticmethod
    def _is_input(msg: mavlink.MAVLink_message | None) -> bool:
        # Not an aPad's position: a docked aMussel goes where its aPad was last heard at the model's next step
        # (lockstep's goes each second), which an input, a timer or a band brings; where it matters, at its
        # release (a slot's report, an input), it is there.
        return msg is None or isinstance(msg, _INPUTS)

    def input_coming(self, msg: mavlink.MAVLink_message | None) -> None:
        """Before a valid message (None: one heard acoustically) acts: the model brought up to date."""
        self._coming = self._is_input(msg)
        if self._coming:
            self.catch_up(self.scheduler.now_us)

    def input_taken(self) -> None:
        """After it acted: the next step at the first step instant after now if it was an input."""
        if not self._coming:
            return
        at = self.grid.after_us(self.scheduler.now_us)
        task = self.task
        if not task.active or task.next_us > at:
            self.scheduler.reschedule(task, next_us=at, active=True)
