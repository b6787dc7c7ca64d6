"""The fleet's MAVLink edge: publishes every aMussel as the dialect's messages, turns incoming
traffic into `FleetInputs`, and steps the pure model at 1 Hz of mission time.

The fleet is one MAVLink system (251, component 25) speaking for all its simulated aMussels, the
way the paper's surface-station node did. It listens to:

- GLOBAL_POSITION_INT from aPads (the sender's system id is the aPad id): docked aMussels follow
  them, and an aMussel only surfaces with one within acoustic range;
- DOCK_SLOT_STATUS from aPads: a slot CLOSING or LATCHED on one of our ids docks it; a slot that no
  longer holds an aMussel we docked there (OPEN, RELEASING, another id) releases it, the falling
  edge of its charging on which the paper's aMussel sinks;
- AMUSSEL_COMMAND: SURFACE / SINK for one of our ids;
- AMUSSEL_SLEEP_ORDER: a wake schedule (interval, awake; interval 0: always on) for one of our ids,
  from the same senders, relayed by the same aPads, as AMUSSEL_COMMAND (`mussel_sim.behaviour`);
- AMUSSEL_STATUS with simulated == 0: a real aMussel. Mixing is allowed, sharing an id is not:
  the status is refused, counted and warned about (`MusselIdCollision` says why).

Every incoming message is validated before it acts (`mussel_sim.inbox_checks`: an aPad we expect,
latitude and longitude in range, a slot 1..N_SLOTS, a known latch and command, one of our ids); what
fails is dropped and counted by reason in `dropped` ("invalid:DOCK_SLOT_STATUS:slot"), and a handler
that still raises is caught in `feed`, counted ("handler_error:NAME") and the runner goes on.

Incoming events are queued and become the inputs of the next step, so the model stays pure and a
run in lockstep is deterministic. Refused surface commands are reported as STATUSTEXT warnings.

A sleeping aMussel (ACTIVE on a wake schedule) speaks only when awake: its AMUSSEL_STATUS and
AMUSSEL_SENSORS go out at the first publish after a wake (`fleet_sleep.publish_rows`). A depleted
aMussel says so `report_policy.LAST_WORDS` times more (its brown-out reports: enough that 40 % loss does not hide it),
then its radio is off, as its acoustic modem is (`mussel_sim.modems`): a fleet that depleted costs the
link and the GCS nothing. Every aMussel that speaks reports by exception (`report_policy`): at once when
its state changes, else at each keep-alive window's start; the fleet's node sends a HEARTBEAT every second.

On the event platform (`register(..., events=True)`, `mussel_sim.event_steps`) the model steps only
when something changes, and nothing is periodic: no heartbeat, no keep-alive, no sensors.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mavlink_dialect import Codec, hot, mavlink
from mavlink_dialect.transport import Transport
from missiontime import US_PER_S, Scheduler, Task, seconds_to_us
from mussel_sim.apad_fixes import ApadFixes
from mussel_sim.battery import to_millivolts
from mussel_sim.comms_config import (
    FLEET_COMPONENT_ID,
    FLEET_SYSTEM_ID,
    HEARTBEAT_PERIOD_S,
    MODEL_STEP_S,
    SURFACE_DEPTH_M,
    CommsConfig,
    MusselIdCollision,
)
from mussel_sim.event_grid import EventGrid
from mussel_sim.event_steps import EventSteps
from mussel_sim.fleet import apply_latches, step
from mussel_sim.fleet_orders import PendingOrders
from mussel_sim.fleet_sleep import publish_rows
from mussel_sim.fleet_state import FleetInputs, FleetParams, FleetState, StepEvents
from mussel_sim.geo import LocalFrame
from mussel_sim.inbox_checks import invalid_field
from mussel_sim.recorder import Recorder
from mussel_sim.report_policy import NO_KEEPALIVE_US, ChargerReports, LastWords, ReportByException
from mussel_sim.sensors import DummySensors, SensorField
from mussel_sim.startconfig import MAX_MUSSEL_ID
from mussel_sim.transport_poller import TransportPoller
from mussel_sim.vocabulary import MusselCommand, MusselState

__all__ = ["FLEET_COMPONENT_ID", "FLEET_SYSTEM_ID", "MODEL_STEP_S", "SURFACE_DEPTH_M", "BatchSink", "CommsConfig",
           "FleetRunner", "MusselIdCollision"]

DEG_E7 = 1e7
STATUSTEXT_MAX = 50

# Where a co-located router takes whole batches: (message id, frames, columns by wire field name).
BatchSink = Callable[[int, list[bytes], dict[str, Any]], None]


class FleetRunner:
    """Owns the current `FleetState` and its I/O; register its tasks with a `Scheduler`.

    `send` receives one encoded MAVLink 2 frame per call. Incoming frames go to `feed(bytes)` (or a
    parsed message to `handle(msg)`); `poller(transport)` adapts a transport for the scheduler.
    """

    def __init__(
        self,
        state: FleetState,
        params: FleetParams,
        rng: np.random.Generator,
        frame: LocalFrame,
        codec: Codec,
        send: Callable[[bytes], None],
        sensors: SensorField | None = None,
        config: CommsConfig | None = None,
        recorder: Recorder | None = None,
        on_events: Callable[[StepEvents], None] | None = None,
        local: Callable[[mavlink.MAVLink_message], None] | None = None,
        local_batch: BatchSink | None = None,
    ) -> None:
        """`send` gets every encoded frame (the fleet's statuses and sensors packed several to a
        datagram). A party in the same process (the GCS router) that would otherwise parse our bytes
        back takes the objects instead: `local` each single message, and `local_batch`, if given,
        every status and sensor batch as (message id, frames, columns by wire name) in place of `send`."""
        if state.n and int(state.ids[-1]) > MAX_MUSSEL_ID:
            raise ValueError(f"aMussel ids above {MAX_MUSSEL_ID} cannot be sent over MAVLink (uint16 mussel_id)")
        self.state = state
        self.params = params
        self.rng = rng
        self.frame = frame
        self.codec = codec
        self.send = send
        self.sensors: SensorField = sensors if sensors is not None else DummySensors()
        self.config = config or CommsConfig()
        self.recorder = recorder if recorder is not None else Recorder(state.ids, start_us=state.time_us)
        self.on_events = on_events
        self.local = local
        self.local_batch = local_batch
        self.end_us: int | None = None  # no steps past this mission time (see `register`)
        self._scheduler: Scheduler | None = None
        self._step_task: Task | None = None
        self.last_events: StepEvents | None = None
        self._ids = {int(i) for i in state.ids}
        self.apads = ApadFixes(frame)  # the aPads' positions as heard, and as a step uses them
        self.real_mussel_ids: set[int] = set()
        self.dropped: Counter[str] = Counter()  # received messages refused, by reason
        self.orders = PendingOrders(self._ids)  # heard since the last step, for the next
        self._published_us: dict[int, int] = {}  # message id -> mission time of its last publish
        self.last_words = LastWords()
        # A companion node bridging its aMussels, not a vehicle (the GCS makes no vehicle of it).
        self._heartbeat = mavlink.MAVLink_heartbeat_message(
            mavlink.MAV_TYPE_ONBOARD_CONTROLLER, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, mavlink.MAV_STATE_ACTIVE, 3)
        self.reports = ReportByException(state.n, seconds_to_us(self.config.status_keepalive_s),
                                         seconds_to_us(1.0 / self.config.status_rate_hz))
        self.charger = ChargerReports(self.reports)
        self.event_steps: EventSteps | None = None  # the event platform's stepping (`register`)

    # --- periodic tasks ----------------------------------------------------------------------------

    def register(self, scheduler: Scheduler, start_us: int = 0, end_us: int | None = None,
                 events: bool = False) -> list[Task]:
        """Step first (so a publish at the same instant shows the new state), then publish.

        With `end_us` the model takes no step past that mission time: a run's uptime covers
        exactly its duration even if the mission loop finishes a dock after the end (the latch
        events after it still apply, with no time passing: `fleet.apply_latches`).

        `events`: the event platform's one task (`mussel_sim.event_steps`): the model stepped at the
        step instants where something changes, its statuses by exception right after each step
        (no keep-alive), no heartbeat and no sensors (nothing the GCS records reads AMUSSEL_SENSORS:
        only the .tlog carried them, and the event platform writes none).
        """
        cfg = self.config
        self.end_us = end_us
        self._scheduler = scheduler
        if events:
            period_us = seconds_to_us(cfg.step_period_s)
            self.reports = ReportByException(self.state.n, NO_KEEPALIVE_US, period_us)
            self.charger = ChargerReports(self.reports)
            self.event_steps = EventSteps(self, scheduler, EventGrid(start_us, period_us, end_us))
            self._step_task = self.event_steps.task
            return [self._step_task]
        self._step_task = scheduler.every(
            cfg.step_period_s, self.step_task, "mussel-step", start_us + round(cfg.step_period_s * US_PER_S)
        )
        return [
            self._step_task,
            scheduler.every(HEARTBEAT_PERIOD_S, self.heartbeat_task, "mussel-heartbeat", start_us),
            scheduler.every(1.0 / cfg.status_rate_hz, self.publish_status_task, "mussel-status", start_us),
            scheduler.every(1.0 / cfg.sensors_rate_hz, self.publish_sensors_task, "mussel-sensors", start_us),
        ]

    def resume(self, state: FleetState, rng_state: dict[str, Any], recorder: Recorder) -> None:
        """Continue from a saved state (a resumed mission): the next step falls a whole step period
        after the saved state's time, not after whenever this runner was started."""
        self.state, self.recorder = state, recorder
        self.rng.bit_generator.state = rng_state
        if self.event_steps is not None:
            self.event_steps.resumed()
        elif self._scheduler is not None and self._step_task is not None:
            self._scheduler.reschedule(self._step_task, next_us=state.time_us + self._step_task.period_us)

    def step_task(self, now_us: int) -> None:
        """Advance the model from its own time to `now_us` with the queued inputs."""
        dt_us = now_us - self.state.time_us
        if dt_us <= 0:  # a repeated instant must not step the model twice
            return
        if self.end_us is not None and now_us > self.end_us:
            if self.orders.latches_changed:  # a dock or undock the aPad finished after the end
                self.state = apply_latches(self.state, self.take_inputs(), self.params)  # commands: no use now
            return
        self.step_to(now_us, self.take_inputs())

    def step_to(self, now_us: int, inputs: FleetInputs, periods: int = 1) -> None:
        """One step of the model to `now_us` with `inputs`, recorded as `periods` step periods (the
        event platform's longer steps; their drift spread as so many, `fleet.step`)."""
        dt_us = now_us - self.state.time_us
        before = self.state
        if periods == 1:
            self.state, events = step(before, inputs, self.params, self.rng, dt_us / US_PER_S)
            self.recorder.record(self.state, dt_us)
        else:
            self.state, events = step(before, inputs, self.params, self.rng, dt_us / US_PER_S,
                                      self.config.step_period_s)
            self.recorder.record(self.state, dt_us, periods, before)
        self.last_events = events
        if self.config.report_refusals:
            self._report(events)
        if self.on_events is not None:
            self.on_events(events)

    def heartbeat_task(self, now_us: int) -> None:
        """The fleet's node says it is there, as every MAVLink system does: its aMussels report by
        exception (`report_policy`), so seconds may pass without a status while the link is alive."""
        self._send(self._heartbeat)

    def publish_status_task(self, now_us: int) -> None:
        rows = self.reports.due(self.state.state, self._speaking(hot.AMUSSEL_STATUS, now_us), now_us)
        if rows is None or rows.size:  # none due: nothing sent, no positions converted
            self._send_statuses(rows, now_us)

    def _send_statuses(self, rows: NDArray[np.intp] | None, time_us: int) -> None:
        """AMUSSEL_STATUS of the state's `rows` (None: every aMussel), stamped `time_us`."""
        s = self.state
        ids, x, y, depth, u, state = s.ids, s.x_m, s.y_m, s.depth_m, s.battery_frac, s.state
        if rows is not None:  # some are asleep (or under water, acoustic), or foreseen: the others only
            ids, x, y, depth, u, state = ids[rows], x[rows], y[rows], depth[rows], u[rows], state[rows]
        lat, lon = self.frame.to_geodetic(x, y)
        if self.event_steps is not None:
            self.event_steps.keepalive.said(rows, time_us)
        self._send_batch(hot.AMUSSEL_STATUS, {
            "time_us": time_us, "mussel_id": ids, "lat": np.round(lat * DEG_E7).astype(np.int64),
            "lon": np.round(lon * DEG_E7).astype(np.int64), "depth": depth, "battery": u,
            "battery_voltage": np.round(to_millivolts(u)).astype(np.int64), "state": state,
            "simulated": 1,
        })

    def _report_for_charger(self, apad: int, slot: int, mussel_id: int, latch: int, released: int | None) -> None:
        """What the aPad's charger meters by (`report_policy.ChargerReports`): a report after its slot
        latched, and one now, still docked as the last step left it, of an aMussel its slot lets go."""
        row = None
        if latch == mavlink.DOCK_LATCH_STATE_LATCHED and mussel_id in self._ids:  # mostly a slot's periodic news
            row = int(self.state.index_of([mussel_id])[0][0])
        self.charger.slot(apad, slot, mussel_id, latch, row)
        if released is not None:
            idx, known = self.state.index_of([released])
            if known[0] and self.state.state[idx[0]] == MusselState.DOCKED:
                self._send_statuses(idx[:1], self.state.time_us)

    publish_task = publish_status_task

    def publish_sensors_task(self, now_us: int) -> None:
        s, rows = self.state, self._speaking(hot.AMUSSEL_SENSORS, now_us)
        ids, x, y, depth = s.ids, s.x_m, s.y_m, s.depth_m
        if rows is not None:
            if not rows.size:
                return
            ids, x, y, depth = ids[rows], x[rows], y[rows], depth[rows]
        r = self.sensors.sample(x, y, depth, now_us / US_PER_S)
        self._send_batch(hot.AMUSSEL_SENSORS, {
            "time_us": now_us, "mussel_id": ids, "dissolved_oxygen": r.dissolved_oxygen_mg_l,
            "temperature": r.temperature_degc, "pressure": r.pressure_hpa, "turbidity": r.turbidity_ntu,
        })

    def _speaking(self, spec: hot.HotSpec, now_us: int) -> NDArray[np.intp] | None:
        """The rows of the state that publish `spec` now (None: all): a sleeping aMussel only after a
        wake, a depleted one only its last words; in an acoustic scenario only those at the surface
        (`CommsConfig.wifi_at_surface_only`)."""
        rows = self._powered(spec.msg_id, publish_rows(self.state, self.params.theta,
                                                        self._published_us.get(spec.msg_id), now_us))
        self._published_us[spec.msg_id] = now_us
        if not self.config.wifi_at_surface_only:
            return rows
        at_surface = np.flatnonzero(self.state.depth_m <= SURFACE_DEPTH_M)
        return at_surface if rows is None else np.intersect1d(rows, at_surface)

    def _powered(self, msg_id: int, rows: NDArray[np.intp] | None) -> NDArray[np.intp] | None:
        return self.last_words.powered(self.state.state, msg_id, rows)

    def heard_acoustically(self, mussel_id: int, command: MusselCommand | None) -> None:
        """An aMussel's modem heard the GCS: a `command` for it (a call-up: SURFACE), or, with None,
        the wake-up ping (`PendingOrders.heard_acoustically`, timed by the fleet's last step: a pinged
        one listens 5 to 6 s). Taken at the next step like a command over MAVLink; an id not ours is
        counted."""
        if mussel_id not in self._ids:
            self.dropped["invalid:acoustic:mussel_id"] += 1
            return
        if self.event_steps is not None:  # the model brought to lockstep's last step first: the ping's time
            self.event_steps.input_coming(None)
        self.orders.heard_acoustically(mussel_id, command, self.state.time_us)
        if self.event_steps is not None:
            self.event_steps.input_taken()

    def _send_batch(self, spec: hot.HotSpec, columns: dict[str, Any]) -> None:
        """One message per aMussel, packed as a batch: byte for byte what one-by-one encoding makes."""
        if not np.size(columns["mussel_id"]):
            return
        frames = hot.encode_batch(self.codec, spec, columns)
        if self.local_batch is not None:
            self.local_batch(spec.msg_id, frames, columns)
        else:
            for datagram in hot.pack_datagrams(frames):
                self.send(datagram)

    # --- incoming ---------------------------------------------------------------------------------------

    def feed(self, data: bytes) -> int:
        """Parse bytes with this runner's codec and handle every message; returns how many.
        Never raises for what arrived: a handler's error is counted and the next message read."""
        msgs = self.codec.decode(data)
        for msg in msgs:
            try:
                self.handle(msg)
            except Exception:  # validation should have stopped it; a bug must not end the fleet
                self.dropped[f"handler_error:{msg.get_type()}"] += 1
        return len(msgs)

    def handle(self, msg: mavlink.MAVLink_message) -> None:
        """Validate one message, then act on it; what fails is counted in `dropped`."""
        src = int(msg.get_srcSystem())
        if src == self.codec.system_id:
            return  # our own traffic echoed back by a router
        bad = invalid_field(msg, src, self.config.apad_ids, self.config.commanders, self._ids)
        if bad is not None:
            self.dropped[f"invalid:{msg.get_type()}:{bad}"] += 1
            return
        if self.event_steps is None:
            self._act(msg, src)
        else:  # an input: the model brought to lockstep's last step before it, the next step after it
            self.event_steps.input_coming(msg)
            self._act(msg, src)
            self.event_steps.input_taken()

    def _act(self, msg: mavlink.MAVLink_message, src: int) -> None:
        if isinstance(msg, mavlink.MAVLink_global_position_int_message):
            heard_us = None if self.event_steps is None or self._scheduler is None else self._scheduler.now_us
            self.apads.hear(src, (msg.lat / DEG_E7, msg.lon / DEG_E7), heard_us)
        elif isinstance(msg, mavlink.MAVLink_dock_slot_status_message):
            released = self.orders.slot_status(src, msg.slot, msg.mussel_id, msg.latch)
            if self.reports.keepalive_us:
                self._report_for_charger(src, msg.slot, msg.mussel_id, msg.latch, released)
        elif isinstance(msg, mavlink.MAVLink_amussel_command_message):
            self.orders.command(msg.mussel_id, MusselCommand.SURFACE if msg.command == MusselCommand.SURFACE
                                else MusselCommand.SINK)
        elif isinstance(msg, mavlink.MAVLink_amussel_sleep_order_message):
            # float32 as on the wire, also for an order handed over in-process (not parsed back)
            self.orders.sleep_order(msg.mussel_id, float(np.float32(msg.interval)), float(np.float32(msg.awake)))
        elif isinstance(msg, mavlink.MAVLink_amussel_status_message) and msg.simulated == 0:
            mussel_id = msg.mussel_id
            if mussel_id in self._ids:  # refused: neither may stand for the other
                self.dropped["id_collision:AMUSSEL_STATUS"] += 1
                if self.dropped["id_collision:AMUSSEL_STATUS"] == 1:
                    self._warn(f"aMussel {mussel_id} also reported by system {src}: refused")
                return
            self.real_mussel_ids.add(mussel_id)

    def poller(self, transport: Transport) -> TransportPoller:
        """A scheduler poller that feeds whatever `transport` received into this runner."""
        return TransportPoller(transport, self.feed)

    def bring_up_to(self, now_us: int) -> None:
        """The model where lockstep's is at `now_us`, for a part that reads `state` between the fleet's
        own steps (the acoustic modems): on the event platform a step with no input (`EventSteps.catch_up`);
        in lockstep it is there already."""
        if self.event_steps is not None:
            self.event_steps.catch_up(now_us)

    # --- internals --------------------------------------------------------------------------------------

    def quiet_inputs(self, step_us: int | None = None) -> FleetInputs:
        """A step's inputs with nothing queued taken: the aPads' positions only (heard before `step_us`)."""
        return FleetInputs.make(apads=self.apads.for_step(self.state, False, step_us))

    def take_inputs(self, step_us: int | None = None) -> FleetInputs:
        """The queued inputs for the next step (the queue is empty after), with the aPads' positions (heard
        before `step_us`)."""
        return self.orders.take(self.apads.for_step(self.state, self.orders.pending, step_us))

    def _report(self, events: StepEvents) -> None:
        if not (events.surface_refused_out_of_range_ids.size or events.surface_refused_depleted_ids.size):
            return
        for mussel_id in events.surface_refused_out_of_range_ids:
            self._warn(f"aMussel {mussel_id}: SURFACE refused, no aPad in {self.params.acoustic_range_m:g} m")
        for mussel_id in events.surface_refused_depleted_ids:
            self._warn(f"aMussel {mussel_id}: SURFACE refused, depleted")

    def _warn(self, text: str) -> None:
        self._send(mavlink.MAVLink_statustext_message(mavlink.MAV_SEVERITY_WARNING, text[:STATUSTEXT_MAX].encode()))

    def _send(self, msg: mavlink.MAVLink_message) -> None:
        self.send(self.codec.encode(msg))
        if self.local is not None:
            self.local(msg)
