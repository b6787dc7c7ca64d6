"""Modes, arming and the GCS failsafe of the aPad: ArduRover's HOLD and GUIDED, as stock tools expect.

HOLD runs Hold Position; GUIDED takes Go To targets (and holds until one comes). DO_SET_MODE and
the legacy SET_MODE message switch between them; COMPONENT_ARM_DISARM arms (the aPad boots armed).
The failsafe: with FS_GCS_ENABLE, a GCS heard once and then silent for FS_GCS_TIMEOUT makes a busy
aPad hold where it is; a Dock or Undock's latch carries on. Mode and arming are the aPad's state
(`ApadState.mode`, `.armed`); this part changes them with `set_mode` and `set_armed`, and whoever
listens (the event log, the HEARTBEAT sent at once) is the core's wiring, not this part's business.

Timing: each GCS heartbeat moves a one-shot deadline task to FS_GCS_TIMEOUT after it, so HOLD comes
FS_GCS_TIMEOUT after the last heartbeat with no check period on top (the physics tick at 10 Hz
used to add up to 0.1 s, and a strict `>` another tick). The physics step still checks too, for a
timeout changed at run time or a Go To that arrives after the deadline. On a wall clock a
heartbeat is dated by the vehicle's latest task (at most a physics step before it arrived), so the
failsafe can come that much early, never late.
"""

from __future__ import annotations

from typing import Any

from apad_sitl import messages as msgs
from apad_sitl import primitives as prim
from apad_sitl.host import ACCEPT, DENY, Command, CommandRegistry, PartHost, Reply, invalid, whole
from apad_sitl.params import ApadParams
from apad_sitl.state import ApadState
from apad_sitl.vocabulary import Primitive, Progress, RoverMode
from mavlink_dialect import mavlink
from missiontime import US_PER_S, Scheduler, Task
from mussel_sim.memo import LastMade

UINT8_MAX = 0xFF
UINT32_MAX = 0xFFFF_FFFF
# The deadline task is one-shot: between heartbeats it sleeps this long (a heartbeat moves it).
_IDLE_US = 3600 * US_PER_S


def mode_name(mode: int) -> str:
    try:
        return RoverMode(mode).name
    except ValueError:
        return str(mode)


class Modes:
    """The vehicle's mode part; also answers GCS heartbeats (the failsafe's input)."""

    def __init__(self, host: PartHost, apad: ApadState, commands: CommandRegistry) -> None:
        self._host = host
        self._apad = apad
        self.last_gcs_heartbeat_us: int | None = None  # mission time of the last GCS HEARTBEAT
        self.failsafe_active = False
        self.failsafe_holds = 0  # times the failsafe stopped what the aPad was doing and held
        self._scheduler: Scheduler | None = None
        self._deadline: Task | None = None
        self._timeout = LastMade(_timeout_us)  # read once per parameter set (PARAM_SET swaps them whole)
        host.on(mavlink.MAVLINK_MSG_ID_HEARTBEAT, self._on_heartbeat)
        host.on(mavlink.MAVLINK_MSG_ID_SET_MODE, self._on_set_mode)
        commands.register(mavlink.MAV_CMD_DO_SET_MODE, self._cmd_set_mode, stateful=True)
        commands.register(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, self._cmd_arm, stateful=True)

    def attach(self, scheduler: Scheduler, start_us: int, name: str, parked: bool = False) -> None:
        """The failsafe's deadline task, idle until a GCS heartbeat sets it: waking each _IDLE_US, or with
        `parked` off the scheduler until then (an ideal link, whose GCS sends none: nothing runs)."""
        self._scheduler = scheduler
        self._deadline = scheduler.every(_IDLE_US / US_PER_S, self._on_deadline, f"{name}.failsafe",
                                         start_us + _IDLE_US)
        if parked:
            scheduler.reschedule(self._deadline, active=False)

    # ------------------------------------------------------------------ modes

    def enter_hold(self) -> None:
        """HOLD mode running Hold Position: at the point already held, else where the hull is.

        A Dock or Undock in progress gives way to Hold, its latch carries on.
        """
        apad = self._apad
        apad.set_mode(RoverMode.HOLD)
        p = apad.primitive
        if p.kind != Primitive.HOLD:
            hx, hy = prim.hold_point(p, apad.state.x_m, apad.state.y_m)
            apad.set_primitive(prim.hold(p, hx, hy))

    def enter_guided(self) -> None:
        """GUIDED mode; with nothing to do it holds where it is until a target comes."""
        apad = self._apad
        apad.set_mode(RoverMode.GUIDED)
        if apad.primitive.kind == Primitive.IDLE:
            apad.set_primitive(prim.hold(apad.primitive, apad.state.x_m, apad.state.y_m))

    def _change_mode(self, base_mode: int, custom_mode: int, custom_field: str) -> Reply:
        if not base_mode & mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            return DENY
        if custom_mode == RoverMode.HOLD:
            self.enter_hold()
            return ACCEPT
        if custom_mode == RoverMode.GUIDED:
            self.enter_guided()
            return ACCEPT
        return invalid(custom_field)  # not a mode of the aPad

    def _cmd_set_mode(self, cmd: Command) -> Reply:
        base_mode = whole(cmd.params[0], 0, UINT8_MAX)
        if base_mode is None:
            return invalid(cmd.field(1))
        custom_mode = whole(cmd.params[1], 0, UINT32_MAX)
        if custom_mode is None:
            return invalid(cmd.field(2))
        return self._change_mode(base_mode, custom_mode, cmd.field(2))

    def _on_set_mode(self, msg: Any) -> None:
        """Legacy SET_MODE message; ArduPilot answers it with a COMMAND_ACK too."""
        host = self._host
        if not host.for_us(msg.target_system, 0):  # SET_MODE names a system, no component
            return
        reply = self._change_mode(msg.base_mode, msg.custom_mode, "custom_mode")
        if reply.invalid is not None:
            host.count_invalid("SET_MODE", reply.invalid)
        host.send(msgs.command_ack(mavlink.MAVLINK_MSG_ID_SET_MODE, reply.result, 0,
                                   msg.get_srcSystem(), msg.get_srcComponent()))

    # ------------------------------------------------------------------ arming

    def _cmd_arm(self, cmd: Command) -> Reply:
        if cmd.params[0] not in (0.0, 1.0):
            return invalid(cmd.field(1))
        self._apad.set_armed(cmd.params[0] == 1.0)
        return ACCEPT

    # ------------------------------------------------------------------ GCS failsafe

    def _on_heartbeat(self, msg: Any) -> None:
        if msg.type != mavlink.MAV_TYPE_GCS:
            return
        host = self._host
        self.last_gcs_heartbeat_us = host.now_us
        if self._scheduler is not None and self._deadline is not None and not host.closed:
            self._scheduler.reschedule(self._deadline, next_us=host.now_us + self._timeout_us(), active=True)

    def _timeout_us(self) -> int:
        return self._timeout(self._apad.params)

    def _on_deadline(self, now_us: int) -> None:
        host = self._host
        if host.closed:
            return
        host.now_us = max(host.now_us, now_us)
        if self._apad.params.fs_gcs_enable:
            self.check_failsafe()

    def gcs_link_lost(self) -> bool:
        """True if a GCS was heard and has been silent for FS_GCS_TIMEOUT (or longer)."""
        last = self.last_gcs_heartbeat_us
        return last is not None and self._host.now_us - last >= self._timeout_us()

    def check_failsafe(self) -> None:
        """Called at the deadline and every physics step while FS_GCS_ENABLE is set."""
        if not self.gcs_link_lost():
            self.failsafe_active = False
            return
        # Anything but holding: a Go To stops; a Dock or Undock gives way to Hold and its latch carries on,
        # so docked aMussels stay latched and charging. The GCS re-commands what it wants when it is back.
        host, p = self._host, self._apad.primitive
        busy = p.kind != Primitive.HOLD and p.progress == Progress.IN_PROGRESS
        if busy and not self.failsafe_active:
            self.failsafe_active = True
            self.failsafe_holds += 1
            host.statustext(mavlink.MAV_SEVERITY_WARNING, "GCS failsafe: heartbeat lost, holding")
            silent_us = host.now_us - (self.last_gcs_heartbeat_us or 0)
            host.event("failsafe", reason="gcs heartbeat lost", silent_s=round(silent_us / US_PER_S, 6))
            self.enter_hold()


def _timeout_us(params: ApadParams) -> int:
    """FS_GCS_TIMEOUT in mission microseconds."""
    return round(params.fs_gcs_timeout_s * US_PER_S)
