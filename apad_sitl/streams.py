"""Telemetry of the aPad: periodic streams, SET_MESSAGE_INTERVAL, requested messages, on-change status.

One scheduler task per stream, at its rate in mission time (`DEFAULT_RATES_HZ`, overridable per
vehicle and at run time by SET_MESSAGE_INTERVAL). REQUEST_MESSAGE (and the older
REQUEST_AUTOPILOT_CAPABILITIES, GET_HOME_POSITION) sends one message after the ACK.
PRIMITIVE_STATUS and DOCK_SLOT_STATUS also go out the moment they change (`announce`), so a
script never waits a stream period to see its command take effect: the vehicle's core makes
`primitive_changed` a listener of the primitive, and `send_heartbeat` one of mode and arming.

On an ideal link (`by_exception`, the event platform's) a stream reports by exception: at its period
it sends only what differs from what it last sent (`apad_sitl.by_exception`); HEARTBEAT goes once
at attach and then with each change of mode or arming, as it does at once anyway. Nothing runs where
nothing happens: while the hull rests with its physics task parked (`apad_sitl.parking`), each
stream fires next at the first instant of its grid at which its message would differ, over the
rest's closed form, and is parked when it never would; `wake` (the physics ticking again: a command
handled, a setter of the state) puts them back on their grid. The battery's rule: a resting hull's
battery drains (or charges at home) with no tick, so SYS_STATUS and BATTERY_STATUS fire at the
first instant of their grid at which the value they report has changed (a draining rest: in closed
form, `rest.Rest.after`; a charging rest, which has none: at every instant of their grid until
full). The GCS's battery is thus at every instant what a stream sending every period would have
told it: never staler than the stream's period.

A requested interval shorter than MIN_INTERVAL_US (20 ms, 50 Hz) is clamped to it and ACCEPTED, as
ArduPilot does with rates above its limit: a stock GCS asking for "as fast as you can" gets a rate,
and nobody gets a stream flood on request (1 µs used to be granted).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

from apad_sitl import by_exception as bx
from apad_sitl import messages as msgs
from apad_sitl.dege7 import DegE7
from apad_sitl.host import ACCEPT, ACCEPTED, DENY, Command, CommandRegistry, PartHost, Reply, invalid, whole
from apad_sitl.primitives import PrimitiveState, SlotState
from apad_sitl.state import ApadState
from apad_sitl.vehicle import VehicleState
from apad_sitl.vocabulary import N_SLOTS, Primitive
from mavlink_dialect import mavlink
from missiontime import US_PER_S, Scheduler, Task
from mussel_sim.geo import LocalFrame

# Telemetry streams: message id -> default rate in Hz (0: only on request or SET_MESSAGE_INTERVAL).
DEFAULT_RATES_HZ: dict[int, float] = {
    mavlink.MAVLINK_MSG_ID_HEARTBEAT: 1.0,
    mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 4.0,
    mavlink.MAVLINK_MSG_ID_SYS_STATUS: 1.0,
    mavlink.MAVLINK_MSG_ID_BATTERY_STATUS: 1.0,
    mavlink.MAVLINK_MSG_ID_PRIMITIVE_STATUS: 2.0,
    mavlink.MAVLINK_MSG_ID_DOCK_SLOT_STATUS: 1.0,  # every slot at this rate
    mavlink.MAVLINK_MSG_ID_ATTITUDE: 0.0,
    mavlink.MAVLINK_MSG_ID_VFR_HUD: 0.0,
    mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE: 0.0,
    mavlink.MAVLINK_MSG_ID_HOME_POSITION: 0.0,
    mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION: 0.0,
}
MAX_MSG_ID = 2**24 - 1  # MAVLink 2 message ids are 24 bits
MAX_INTERVAL_US = 2**31 - 1  # an int32 of microseconds (~36 min); longer is a typo, not a rate
MIN_INTERVAL_US = 20_000  # 50 Hz per stream at most, whatever is asked
# Streams whose message changes only where it is sent at once anyway (mode, arming): by exception, one
# report at attach and none periodic.
AT_ONCE_ONLY = frozenset({mavlink.MAVLINK_MSG_ID_HEARTBEAT})

Message = mavlink.MAVLink_message
# A stream's messages at an instant, of the hull `state` (None: the hull now, read where each reads it).
Build = Callable[[int, VehicleState | None], list[Message]]


class Streams:
    """The vehicle's telemetry part. `attach` makes the tasks; `stop` ends them.

    It sends what `apad` holds; `frame` is the local frame around home (positions to degE7, and
    HOME_POSITION). `target_e7` converts the primitive's target: the core shares it with navigation,
    which remembers a Go To's target as commanded.
    """

    def __init__(
        self,
        host: PartHost,
        apad: ApadState,
        commands: CommandRegistry,
        frame: LocalFrame,
        system_id: int,
        rates_hz: Mapping[int, float] | None = None,
        target_e7: DegE7 | None = None,
        by_exception: bool = False,
    ) -> None:
        """`by_exception`: the ideal link's telemetry (the module's docstring)."""
        self._host = host
        self._apad = apad
        self._frame = frame
        self._system_id = system_id
        self.position_e7 = DegE7(frame)  # where the aPad is
        self.target_e7 = target_e7 if target_e7 is not None else DegE7(frame)  # where its primitive is going
        self._rates_hz = dict(DEFAULT_RATES_HZ)
        for msg_id, hz in (rates_hz or {}).items():
            if msg_id not in DEFAULT_RATES_HZ:
                raise ValueError(f"message id {msg_id} is not a telemetry stream of the aPad")
            self._rates_hz[msg_id] = hz
        self._interval_us = {mid: hz_to_us(hz) for mid, hz in self._rates_hz.items()}
        self._scheduler: Scheduler | None = None
        self._tasks: dict[int, Task] = {}
        self._sent_primitive: tuple[Any, ...] | None = None
        self._sent_slots: list[SlotState | None] = [None] * N_SLOTS
        self.by_exception = by_exception
        self._last: dict[tuple[int, int], tuple[Any, ...]] = {}  # by exception: each stream's last report
        self._resting: set[int] = set()  # by exception: streams off their period while the hull rests
        self._rest: bx.Resting | None = None

        def now_or(state: VehicleState | None) -> VehicleState:
            return apad.state if state is None else state

        # What each stream sends, built (pure); its sender sends it.
        self._builders: dict[int, Build] = {
            mavlink.MAVLINK_MSG_ID_HEARTBEAT: lambda now, s: [msgs.heartbeat(apad.mode, apad.armed)],
            mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: self._position,
            mavlink.MAVLINK_MSG_ID_SYS_STATUS: lambda now, s: [msgs.sys_status(now_or(s))],
            mavlink.MAVLINK_MSG_ID_BATTERY_STATUS: lambda now, s: [msgs.battery_status(now_or(s), apad.energy)],
            mavlink.MAVLINK_MSG_ID_PRIMITIVE_STATUS: self._primitive_status,
            mavlink.MAVLINK_MSG_ID_DOCK_SLOT_STATUS: lambda now, s: [
                msgs.dock_slot_status(now, slot, apad.primitive.slot_state(slot)) for slot in range(1, N_SLOTS + 1)],
            mavlink.MAVLINK_MSG_ID_ATTITUDE: lambda now, s: [msgs.attitude(now, now_or(s))],
            mavlink.MAVLINK_MSG_ID_VFR_HUD: lambda now, s: [msgs.vfr_hud(now_or(s), apad.params)],
            mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE: lambda now, s: [msgs.extended_sys_state()],
            mavlink.MAVLINK_MSG_ID_HOME_POSITION: self._home,
            mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION: lambda now, s: [msgs.autopilot_version(system_id)],
        }
        self._senders: dict[int, Callable[[int], None]] = {msg_id: self._sender(build)
                                                           for msg_id, build in self._builders.items()}
        self._senders[mavlink.MAVLINK_MSG_ID_HEARTBEAT] = lambda now: self.send_heartbeat()
        self._senders[mavlink.MAVLINK_MSG_ID_PRIMITIVE_STATUS] = self._send_primitive_status
        self._senders[mavlink.MAVLINK_MSG_ID_DOCK_SLOT_STATUS] = self._send_all_slots
        commands.register(mavlink.MAV_CMD_REQUEST_MESSAGE, self._cmd_request_message)
        commands.register(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, self._cmd_set_message_interval)
        commands.register(mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, self._cmd_request_autopilot_capabilities)
        commands.register(mavlink.MAV_CMD_GET_HOME_POSITION, self._cmd_get_home_position)

    # ------------------------------------------------------------------ tasks

    def attach(self, scheduler: Scheduler, start_us: int, name: str, rest: bx.Resting | None = None) -> None:
        """One task per stream, first firing at `start_us` if its rate is not 0. By exception, `rest` is the
        physics task the streams park with (None: they never park)."""
        self._scheduler = scheduler
        self._rest = rest
        for msg_id, sender in self._senders.items():
            callback = self._report_callback(msg_id) if self.by_exception else self._stream_callback(sender)
            task = scheduler.every(1.0, callback, f"{name}.{_msg_name(msg_id)}", start_us)
            self._tasks[msg_id] = task
            self._apply_interval(msg_id, task, start_us)

    def stop(self) -> None:
        self._resting.clear()
        for task in self._tasks.values():
            task.active = False

    def wake(self) -> None:
        """By exception: the streams parked or sent ahead while the hull rested back on their grid at the
        next instant a stream ticking throughout would run (the physics ticks again: what they report may
        change)."""
        scheduler = self._scheduler
        if scheduler is None or self._host.closed:
            return
        for msg_id in self._resting:
            task = self._tasks[msg_id]
            if self._interval_us[msg_id] > 0:
                scheduler.reschedule(task, next_us=bx.next_on_grid(task, scheduler), active=True)
        self._resting.clear()

    def _report_callback(self, msg_id: int) -> Callable[[int], None]:
        """A stream by exception: what differs from its last report sent, then when it fires next."""
        host, build = self._host, self._builders[msg_id]

        def callback(now_us: int) -> None:
            host.now_us = now_us
            self._resting.discard(msg_id)
            built = build(now_us, None)
            for msg in built:
                if self._last.get(bx.stream_of(msg)) != bx.report_key(msg):
                    self._send_report(msg)
            task = self._tasks[msg_id]
            if msg_id in AT_ONCE_ONLY:
                task.active = False
            else:
                self._plan(msg_id, task, now_us, built)

        return callback

    def _send_report(self, msg: Message) -> None:
        self._emit(msg)
        msg_id = msg.get_msgId()
        if msg_id == mavlink.MAVLINK_MSG_ID_PRIMITIVE_STATUS:
            self._sent_primitive = self._primitive_key()
        elif msg_id == mavlink.MAVLINK_MSG_ID_DOCK_SLOT_STATUS:
            _, slot = bx.stream_of(msg)
            self._sent_slots[slot - 1] = self._apad.primitive.slot_state(slot)

    def _plan(self, msg_id: int, task: Task, now_us: int, built: list[Message]) -> None:
        """While the hull rests parked: on to the first instant of the grid whose message differs, or
        parked if none will (a charging rest, with no closed form: at its period)."""
        ahead = self._rest.ahead() if self._rest is not None else None
        if ahead is None or self._scheduler is None:
            return  # the physics ticks: at the stream's period
        build, now_keys = self._builders[msg_id], bx.keys(built)
        if bx.keys(build(now_us, ahead.end)) == now_keys:  # it would only repeat itself: parked
            self._scheduler.reschedule(task, active=False)
            self._resting.add(msg_id)
            return
        still_us = ahead.still_us
        if still_us is None:
            return
        period = task.period_us
        k_end = max(1, -((now_us - still_us) // period))  # the first instant of the grid at or after still_us

        def differs(k: int) -> bool:
            t_us = now_us + k * period
            return bx.keys(build(t_us, ahead.hull_at(t_us))) != now_keys

        k = bx.first_change(differs, k_end)
        if k > 1:
            self._scheduler.reschedule(task, next_us=now_us + k * period)
            self._resting.add(msg_id)

    def _stream_callback(self, sender: Callable[[int], None]) -> Callable[[int], None]:
        host = self._host

        def callback(now_us: int) -> None:
            host.now_us = now_us
            sender(now_us)

        return callback

    def _apply_interval(self, msg_id: int, task: Task, now_us: int) -> None:
        if msg_id in self._resting and self._scheduler is not None:  # on its grid, as if it had kept ticking
            self._resting.discard(msg_id)
            self._scheduler.reschedule(task, next_us=bx.next_on_grid(task, self._scheduler), active=True)
        interval_us = self._interval_us[msg_id]
        if interval_us > 0 and not self._host.closed and self._scheduler is not None:
            self._scheduler.reschedule(task, period_us=interval_us, next_us=next_send_us(task, now_us, interval_us),
                                       active=True)
        else:
            task.active = False

    # ------------------------------------------------------------------ commands

    def _cmd_request_message(self, cmd: Command) -> Reply:
        msg_id = whole(cmd.params[0], 0, MAX_MSG_ID)
        if msg_id is None:
            return invalid(cmd.field(1))
        if msg_id not in self._senders:
            return DENY  # a message, but not one the aPad sends
        if msg_id == mavlink.MAVLINK_MSG_ID_DOCK_SLOT_STATUS:
            slot = whole(cmd.params[1], 0, N_SLOTS)  # param2 picks one slot; 0 sends all four
            if slot is None:
                return invalid(cmd.field(2))
            if slot:
                return Reply(ACCEPTED, then=lambda: self.send_slot(slot))
        return Reply(ACCEPTED, then=lambda: self._senders[msg_id](self._host.now_us))

    def _cmd_request_autopilot_capabilities(self, cmd: Command) -> Reply:
        return Reply(ACCEPTED, then=lambda: self._senders[mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION](self._host.now_us))

    def _cmd_get_home_position(self, cmd: Command) -> Reply:
        return Reply(ACCEPTED, then=lambda: self._senders[mavlink.MAVLINK_MSG_ID_HOME_POSITION](self._host.now_us))

    def _cmd_set_message_interval(self, cmd: Command) -> Reply:
        msg_id = whole(cmd.params[0], 0, MAX_MSG_ID)
        if msg_id is None:
            return invalid(cmd.field(1))
        if msg_id not in self._senders:
            return DENY
        interval = cmd.params[1]
        if interval == -1:  # MAVLink: stop sending it
            interval_us = 0
        elif interval == 0:  # MAVLink: back to the default rate
            interval_us = hz_to_us(self._rates_hz[msg_id])
        elif math.isfinite(interval) and 1 <= interval <= MAX_INTERVAL_US:
            interval_us = max(int(interval), MIN_INTERVAL_US)
        else:
            return invalid(cmd.field(2))
        self._interval_us[msg_id] = interval_us
        task = self._tasks.get(msg_id)
        if task is not None:
            self._apply_interval(msg_id, task, self._host.now_us)
        return ACCEPT

    # ------------------------------------------------------------------ sending

    def send_heartbeat(self) -> None:
        """A HEARTBEAT now (also the listener of mode and arming: consoles show a change at once)."""
        apad = self._apad
        if not self._host.closed:
            self._emit(msgs.heartbeat(apad.mode, apad.armed))

    def _emit(self, msg: Message) -> None:
        """Send a stream's message (periodic, requested or at once); by exception, remember it as its last."""
        self._host.send(msg)
        if self.by_exception:
            self._last[bx.stream_of(msg)] = bx.report_key(msg)

    def _sender(self, build: Build) -> Callable[[int], None]:
        def send(now_us: int) -> None:
            for msg in build(now_us, None):
                self._emit(msg)

        return send

    def _position(self, now_us: int, state: VehicleState | None) -> list[Message]:
        state = self._apad.state if state is None else state
        lat_e7, lon_e7 = self.position_e7.of(state.x_m, state.y_m)
        return [msgs.global_position_int(now_us, lat_e7, lon_e7, state)]

    def _home(self, now_us: int, state: VehicleState | None) -> list[Message]:
        frame = self._frame
        return [msgs.home_position(now_us, round(frame.origin_lat_deg * 1e7), round(frame.origin_lon_deg * 1e7))]

    def _primitive_key(self) -> tuple[Any, ...]:
        p = self._apad.primitive
        return (p.kind, p.progress, p.target_x_m, p.target_y_m, p.slot, p.mussel_id)

    def _primitive_status(self, now_us: int, state: VehicleState | None) -> list[Message]:
        apad = self._apad
        p = apad.primitive
        lat_e7, lon_e7 = (0, 0) if p.kind == Primitive.IDLE else self.target_e7.of(p.target_x_m, p.target_y_m)
        return [msgs.primitive_status(now_us, p, lat_e7, lon_e7, apad.state if state is None else state)]

    def _send_primitive_status(self, now_us: int) -> None:
        for msg in self._primitive_status(now_us, None):
            self._emit(msg)
        self._sent_primitive = self._primitive_key()

    def send_slot(self, slot: int) -> None:
        s = self._apad.primitive.slot_state(slot)
        self._emit(msgs.dock_slot_status(self._host.now_us, slot, s))
        self._sent_slots[slot - 1] = s

    def _send_all_slots(self, now_us: int) -> None:
        for slot in range(1, N_SLOTS + 1):
            self.send_slot(slot)

    def primitive_changed(self, old: PrimitiveState, new: PrimitiveState) -> None:
        """The listener of the primitive: announce the change, unless the vehicle has closed."""
        if not self._host.closed:
            self.announce()

    def announce(self) -> None:
        """On-change telemetry: every slot that differs from what was last sent, then the primitive."""
        for i, s in enumerate(self._apad.primitive.slots):
            sent = self._sent_slots[i]
            if sent is None or (sent.mussel_id, sent.latch, sent.charging) != (s.mussel_id, s.latch, s.charging):
                self.send_slot(i + 1)
        if self._primitive_key() != self._sent_primitive:
            self._send_primitive_status(self._host.now_us)


def next_send_us(task: Task, now_us: int, interval_us: int) -> int:
    """When a stream whose interval changes to `interval_us` sends next: within one new interval.

    Faster than before: at the first instant after now of its old schedule stepped back by the new
    interval, so the stream keeps its phase (a GCS that slows a stream while the aPad holds and
    speeds it up again sees the same instants as if it had never slowed it). Slower: at its next
    instant already due within the new interval, else one new interval from now.
    """
    if task.active and task.next_us > now_us + interval_us:
        return now_us + (task.next_us - now_us - 1) % interval_us + 1
    return max(now_us, min(task.next_us, now_us + interval_us))


def hz_to_us(hz: float) -> int:
    return round(US_PER_S / hz) if hz > 0 else 0


def _msg_name(msg_id: int) -> str:
    cls = mavlink.mavlink_map.get(msg_id)
    return cls.msgname if cls is not None else str(msg_id)
