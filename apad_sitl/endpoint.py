"""The SITL aPad as a MAVLink vehicle: one system on one transport, driven by the scheduler.

`SitlVehicle` owns the models (vehicle, primitives, params) and speaks MAVLink 2 like an
ArduRover boat: HEARTBEAT, position, battery, COMMAND_ACK for every command addressed to it,
the PARAM protocol, and the dialect's PRIMITIVE_STATUS and DOCK_SLOT_STATUS. `attach(scheduler)`
registers its physics task, one task per telemetry stream, and itself as a poller.

It never reads a clock: tasks receive `now_us` and the vehicle keeps the latest for handling
messages between tasks. Lat/lon <-> metres goes through `LocalFrame` around home.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from apad_sitl import messages as msgs
from apad_sitl import primitives as prim
from apad_sitl import vehicle as veh
from apad_sitl.logs import VehicleLog
from apad_sitl.params import INDEX, PARAMS, ApadParams, ParamError, param_value, with_param
from apad_sitl.primitives import REFUSAL_TEXT, MusselFix, PrimitiveState, Refusal
from apad_sitl.vehicle import VehicleState
from apad_sitl.vocabulary import Latch, Primitive, Progress
from mavlink_dialect import MAV_CMD_APAD_DOCK, MAV_CMD_APAD_UNDOCK, Codec, Transport, mavlink, signing
from missiontime import Scheduler, Task
from mussel_sim.geo import LocalFrame
from mussel_sim.vocabulary import MusselState

US_PER_S = 1_000_000
PHYSICS_HZ = 10.0
# A command identical to the last accepted one from the same source within this window is a
# retransmission (the GCS lost our ACK): re-ACK it, do not execute it again.
RETRY_WINDOW_US = 5 * US_PER_S
# A Go To further than this from home is a typo in the coordinates, not a mission.
MAX_GOTO_FROM_HOME_M = 20_000.0
GLOBAL_FRAMES = frozenset({
    mavlink.MAV_FRAME_GLOBAL,
    mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT,
    mavlink.MAV_FRAME_GLOBAL_INT,
    mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
})

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
# Commands that change the vehicle's state and so take part in retransmission detection.
STATEFUL_COMMANDS = frozenset({
    mavlink.MAV_CMD_DO_REPOSITION,
    mavlink.MAV_CMD_DO_SET_MODE,
    mavlink.MAV_CMD_COMPONENT_ARM_DISARM,
    mavlink.MAV_CMD_DO_CHANGE_SPEED,
    MAV_CMD_APAD_DOCK,
    MAV_CMD_APAD_UNDOCK,
})

ACCEPTED = mavlink.MAV_RESULT_ACCEPTED
DENIED = mavlink.MAV_RESULT_DENIED
UNSUPPORTED = mavlink.MAV_RESULT_UNSUPPORTED


@dataclass(frozen=True)
class Command:
    """A COMMAND_LONG or COMMAND_INT addressed to us, normalised."""

    command: int
    params: tuple[float, ...]  # param1..param7; for COMMAND_INT param5/6 are x/y (degE7) and param7 z
    frame: int | None  # COMMAND_INT frame; None for COMMAND_LONG (whose lat/lon are degrees)
    source_system: int
    source_component: int

    @property
    def key(self) -> tuple[Any, ...]:
        """What makes a retransmission: the same command with the same parameters (NaN == NaN)."""
        return (self.command, self.frame, tuple(p if p == p else None for p in self.params))

    def lat_lon_deg(self) -> tuple[float, float]:
        lat, lon = self.params[4], self.params[5]
        return (lat / 1e7, lon / 1e7) if self.frame is not None else (lat, lon)


@dataclass(frozen=True)
class _Executed:
    key: tuple[Any, ...]
    result: int
    result_param2: int
    time_us: int


class _MusselTable(Mapping[int, MusselFix]):
    """Latest AMUSSEL_STATUS per aMussel; converted to local metres lazily, only when asked."""

    def __init__(self, frame: LocalFrame) -> None:
        self._frame = frame
        self._raw: dict[int, tuple[int, int, int]] = {}  # id -> (lat degE7, lon degE7, state)
        self._fixes: dict[int, MusselFix] = {}

    def update(self, mussel_id: int, lat_e7: int, lon_e7: int, state: int) -> None:
        raw = (lat_e7, lon_e7, state)
        if self._raw.get(mussel_id) != raw:
            self._raw[mussel_id] = raw
            self._fixes.pop(mussel_id, None)

    def __getitem__(self, mussel_id: int) -> MusselFix:
        fix = self._fixes.get(mussel_id)
        if fix is None:
            lat_e7, lon_e7, state = self._raw[mussel_id]
            x, y = self._frame.to_local(lat_e7 / 1e7, lon_e7 / 1e7)
            fix = MusselFix(float(x), float(y), docked=state == MusselState.DOCKED)
            self._fixes[mussel_id] = fix
        return fix

    def __iter__(self) -> Iterator[int]:
        return iter(self._raw)

    def __len__(self) -> int:
        return len(self._raw)


class _DegE7:
    """Local metres -> degE7 through the frame, remembering the last point (most sends repeat it)."""

    def __init__(self, frame: LocalFrame) -> None:
        self.frame = frame
        self._last: tuple[float, float, int, int] = (math.nan, math.nan, 0, 0)

    def remember(self, x_m: float, y_m: float, lat_e7: int, lon_e7: int) -> None:
        self._last = (x_m, y_m, lat_e7, lon_e7)

    def of(self, x_m: float, y_m: float) -> tuple[int, int]:
        cx, cy, lat_e7, lon_e7 = self._last
        if x_m != cx or y_m != cy:
            lat, lon = self.frame.to_geodetic(x_m, y_m)
            lat_e7, lon_e7 = round(float(lat) * 1e7), round(float(lon) * 1e7)
            self._last = (x_m, y_m, lat_e7, lon_e7)
        return lat_e7, lon_e7


class SitlVehicle:
    """A simulated aPad speaking MAVLink on `transport`. Call `attach(scheduler)` to run it."""

    def __init__(
        self,
        transport: Transport,
        params: ApadParams,
        home_lat_deg: float,
        home_lon_deg: float,
        system_id: int = 1,
        current_mps: tuple[float, float] = (0.0, 0.0),
        log_dir: str | Path | None = None,
        component_id: int = mavlink.MAV_COMP_ID_AUTOPILOT1,
        rates_hz: Mapping[int, float] | None = None,
        physics_hz: float = PHYSICS_HZ,
        log_epoch_us: int = 0,
        signing_key: bytes | None = None,
        geofence_deg: Sequence[tuple[float, float]] | None = None,
        log_append: bool = False,
    ) -> None:
        """`rates_hz` overrides DEFAULT_RATES_HZ per message id; `log_epoch_us` offsets .tlog stamps and
        is the Unix time of t = 0 for signing timestamps. With `signing_key` every frame we send is
        signed and commands must be too (the swarm's own telemetry may come unsigned). `geofence_deg`
        is the water area as a (lat, lon) ring: Go To targets outside it and undocking outside it are refused.
        """
        self.transport = transport
        self.params = with_param(params, "SYSID_THISMAV", system_id)
        self.system_id = system_id
        self.component_id = component_id
        self.codec = Codec(system_id, component_id)
        if signing_key is not None:
            self.codec.enable_signing(
                signing_key, link_id=0, ticks=lambda: signing.timestamp_ticks(log_epoch_us, self.now_us),
                allow_unsigned_ids=(mavlink.MAVLINK_MSG_ID_AMUSSEL_STATUS, mavlink.MAVLINK_MSG_ID_AMUSSEL_SENSORS),
            )
        self.frame = LocalFrame(home_lat_deg, home_lon_deg)
        self.geofence = Geofence.of(geofence_deg, self.frame) if geofence_deg else None
        self.home_lat_deg, self.home_lon_deg = home_lat_deg, home_lon_deg
        self.current_mps = current_mps  # (east, north) m/s; scenarios may change it at run time
        self.physics_hz = physics_hz

        self.state = VehicleState()
        self.primitive = PrimitiveState()
        self.mode = msgs.ROVER_MODE_HOLD
        self.armed = True  # boots armed so a mission script needs no arming step
        self.mussels = _MusselTable(self.frame)
        self.now_us = 0
        self.last_gcs_heartbeat_us: int | None = None  # mission time of the last GCS HEARTBEAT
        self.failsafe_active = False
        self.closed = False

        self._speed_override_mps = 0.0  # DO_CHANGE_SPEED for later Go Tos; 0: SPEED_MAX
        self._last_physics_us: int | None = None
        self._executed: dict[tuple[int, int], _Executed] = {}
        self._position_e7 = _DegE7(self.frame)  # where the aPad is
        self._target_e7 = _DegE7(self.frame)  # where its primitive is going
        self._sent_primitive: tuple[Any, ...] | None = None
        self._sent_slots: list[prim.SlotState | None] = [None] * prim.N_SLOTS
        self._scheduler: Scheduler | None = None
        self._tasks: dict[int, Task] = {}
        self._physics_task: Task | None = None
        self._rates_hz = dict(DEFAULT_RATES_HZ)
        if rates_hz:
            for msg_id, hz in rates_hz.items():
                if msg_id not in DEFAULT_RATES_HZ:
                    raise ValueError(f"message id {msg_id} is not a telemetry stream of the aPad")
                self._rates_hz[msg_id] = hz
        self._interval_us = {mid: _hz_to_us(hz) for mid, hz in self._rates_hz.items()}

        self._senders: dict[int, Callable[[int], None]] = {
            mavlink.MAVLINK_MSG_ID_HEARTBEAT: lambda now: self._send_heartbeat(),
            mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: self._send_position,
            mavlink.MAVLINK_MSG_ID_SYS_STATUS: lambda now: self._send(msgs.sys_status(self.state)),
            mavlink.MAVLINK_MSG_ID_BATTERY_STATUS: lambda now: self._send(msgs.battery_status(self.state)),
            mavlink.MAVLINK_MSG_ID_PRIMITIVE_STATUS: self._send_primitive_status,
            mavlink.MAVLINK_MSG_ID_DOCK_SLOT_STATUS: self._send_all_slots,
            mavlink.MAVLINK_MSG_ID_ATTITUDE: lambda now: self._send(msgs.attitude(now, self.state)),
            mavlink.MAVLINK_MSG_ID_VFR_HUD: lambda now: self._send(msgs.vfr_hud(self.state, self.params)),
            mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE: lambda now: self._send(msgs.extended_sys_state()),
            mavlink.MAVLINK_MSG_ID_HOME_POSITION: self._send_home,
            mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION: lambda now: self._send(msgs.autopilot_version(self.system_id)),
        }
        self._handlers: dict[int, Callable[[Any], None]] = {
            mavlink.MAVLINK_MSG_ID_HEARTBEAT: self._on_heartbeat,
            mavlink.MAVLINK_MSG_ID_COMMAND_LONG: self._on_command_long,
            mavlink.MAVLINK_MSG_ID_COMMAND_INT: self._on_command_int,
            mavlink.MAVLINK_MSG_ID_SET_MODE: self._on_set_mode,
            mavlink.MAVLINK_MSG_ID_PARAM_REQUEST_LIST: self._on_param_request_list,
            mavlink.MAVLINK_MSG_ID_PARAM_REQUEST_READ: self._on_param_request_read,
            mavlink.MAVLINK_MSG_ID_PARAM_SET: self._on_param_set,
            mavlink.MAVLINK_MSG_ID_MISSION_REQUEST_LIST: self._on_mission_request_list,
            mavlink.MAVLINK_MSG_ID_FILE_TRANSFER_PROTOCOL: self._on_ftp,
            mavlink.MAVLINK_MSG_ID_AMUSSEL_STATUS: self._on_amussel_status,
        }
        self._commands: dict[int, Callable[[Command], tuple[int, int]]] = {
            mavlink.MAV_CMD_DO_REPOSITION: self._cmd_reposition,
            mavlink.MAV_CMD_DO_SET_MODE: self._cmd_set_mode,
            mavlink.MAV_CMD_COMPONENT_ARM_DISARM: self._cmd_arm,
            mavlink.MAV_CMD_DO_CHANGE_SPEED: self._cmd_change_speed,
            mavlink.MAV_CMD_REQUEST_MESSAGE: self._cmd_request_message,
            mavlink.MAV_CMD_SET_MESSAGE_INTERVAL: self._cmd_set_message_interval,
            mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES: self._cmd_request_autopilot_capabilities,
            mavlink.MAV_CMD_GET_HOME_POSITION: self._cmd_get_home_position,
            MAV_CMD_APAD_DOCK: self._cmd_dock,
            MAV_CMD_APAD_UNDOCK: self._cmd_undock,
        }

        self.log: VehicleLog | None = None
        if log_dir is not None:
            self.log = VehicleLog(Path(log_dir), f"apad{system_id}", log_epoch_us, append=log_append)
            self._event("start", system_id=system_id, home_lat_deg=home_lat_deg, home_lon_deg=home_lon_deg,
                        current_mps=list(current_mps))

    # ------------------------------------------------------------------ lifecycle

    def attach(self, scheduler: Scheduler, start_us: int = 0) -> None:
        """Register the physics task, one task per telemetry stream, and this vehicle as a poller.

        `start_us` is the mission time now (tasks first fire then; a late attach does not replay).
        """
        if self._scheduler is not None:
            raise RuntimeError("vehicle already attached to a scheduler")
        self._scheduler = scheduler
        self.now_us = max(self.now_us, start_us)
        name = f"apad{self.system_id}"
        self._physics_task = scheduler.every(1.0 / self.physics_hz, self._physics, f"{name}.physics", start_us)
        for msg_id, sender in self._senders.items():
            task = scheduler.every(1.0, self._stream_callback(sender), f"{name}.{_msg_name(msg_id)}", start_us)
            self._tasks[msg_id] = task
            self._apply_interval(msg_id, task, start_us)
        scheduler.add_poller(self)

    def close(self) -> None:
        """Stop the tasks, flush and close the logs, close the transport. Idempotent."""
        if self.closed:
            return
        self.closed = True
        for task in (self._physics_task, *self._tasks.values()):
            if task is not None:
                task.active = False
        if self._scheduler is not None:
            self._scheduler.remove_poller(self)
        self._event("close", distance_travelled_m=round(self.state.distance_travelled_m, 3),
                    battery_v=round(self.state.battery_v, 4))
        if self.log is not None:
            self.log.close()
        self.transport.close()

    def __enter__(self) -> SitlVehicle:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ state for embedders and tests

    @property
    def position_deg(self) -> tuple[float, float]:
        """(lat_deg, lon_deg) of the aPad now."""
        lat_e7, lon_e7 = self._position_e7.of(self.state.x_m, self.state.y_m)
        return lat_e7 / 1e7, lon_e7 / 1e7

    def gcs_link_lost(self) -> bool:
        """True if a GCS was heard and has been silent for FS_GCS_TIMEOUT."""
        last = self.last_gcs_heartbeat_us
        return last is not None and self.now_us - last > self.params.fs_gcs_timeout_s * US_PER_S

    # ------------------------------------------------------------------ poller

    def fileno(self) -> int | None:
        return None if self.closed else self.transport.fileno()

    def poll(self) -> bool:
        """Read the transport and handle every message; True if anything arrived."""
        if self.closed:
            return False
        datagrams = self.transport.receive()
        for data in datagrams:
            for msg in self.codec.decode(data):
                if self.log is not None:
                    self.log.message(self.now_us, msg.get_msgbuf())
                handler = self._handlers.get(msg.get_msgId())
                if handler is not None:
                    handler(msg)
        return bool(datagrams)

    # ------------------------------------------------------------------ tasks

    def _stream_callback(self, sender: Callable[[int], None]) -> Callable[[int], None]:
        def callback(now_us: int) -> None:
            self.now_us = now_us
            sender(now_us)

        return callback

    def _physics(self, now_us: int) -> None:
        self.now_us = now_us
        last, self._last_physics_us = self._last_physics_us, now_us
        if last is None:
            return
        dt_s = (now_us - last) / US_PER_S
        if self.log is not None and now_us // US_PER_S != last // US_PER_S:
            self.log.flush()  # once a second of mission time: a killed process loses little
        if self.params.fs_gcs_enable:
            self._check_gcs_failsafe()
        p = self.params
        setpoint = prim.velocity_setpoint(self.primitive, self.state, p) if self.armed else (0.0, 0.0)
        self.state = veh.step(self.state, setpoint, p, self.current_mps, dt_s)
        self._set_primitive(prim.step(self.primitive, self.state.x_m, self.state.y_m, self.mussels, p, dt_s))

    def _check_gcs_failsafe(self) -> None:
        if not self.gcs_link_lost():
            self.failsafe_active = False
            return
        # Anything but holding: a Go To stops; a Dock or Undock gives way to Hold and its latch carries on,
        # so docked aMussels stay latched and charging. The GCS re-commands what it wants when it is back.
        busy = self.primitive.kind != Primitive.HOLD and self.primitive.progress == Progress.IN_PROGRESS
        if busy and not self.failsafe_active:
            self.failsafe_active = True
            self._statustext(mavlink.MAV_SEVERITY_WARNING, "GCS failsafe: heartbeat lost, holding")
            self._event("failsafe", reason="gcs heartbeat lost")
            self._enter_hold()

    # ------------------------------------------------------------------ sending

    def _send(self, msg: mavlink.MAVLink_message) -> None:
        frame = self.codec.encode(msg)
        self.transport.send(frame)
        if self.log is not None:
            self.log.message(self.now_us, frame)

    def _send_heartbeat(self) -> None:
        if not self.closed:
            self._send(msgs.heartbeat(self.mode, self.armed))

    def _send_position(self, now_us: int) -> None:
        lat_e7, lon_e7 = self._position_e7.of(self.state.x_m, self.state.y_m)
        self._send(msgs.global_position_int(now_us, lat_e7, lon_e7, self.state))

    def _send_home(self, now_us: int) -> None:
        self._send(msgs.home_position(now_us, round(self.home_lat_deg * 1e7), round(self.home_lon_deg * 1e7)))

    def _primitive_key(self) -> tuple[Any, ...]:
        p = self.primitive
        return (p.kind, p.progress, p.target_x_m, p.target_y_m, p.slot, p.mussel_id)

    def _send_primitive_status(self, now_us: int) -> None:
        p = self.primitive
        lat_e7, lon_e7 = (0, 0) if p.kind == Primitive.IDLE else self._target_e7.of(p.target_x_m, p.target_y_m)
        self._send(msgs.primitive_status(now_us, p, lat_e7, lon_e7, self.state))
        self._sent_primitive = self._primitive_key()

    def _send_slot(self, slot: int) -> None:
        s = self.primitive.slot_state(slot)
        self._send(msgs.dock_slot_status(self.now_us, slot, s))
        self._sent_slots[slot - 1] = s

    def _send_all_slots(self, now_us: int) -> None:
        for slot in range(1, prim.N_SLOTS + 1):
            self._send_slot(slot)

    def _statustext(self, severity: int, text: str) -> None:
        self._send(msgs.statustext(severity, text))

    def _event(self, event: str, **fields: Any) -> None:
        if self.log is not None:
            self.log.event(self.now_us, event, **fields)

    # ------------------------------------------------------------------ state changes

    def _set_primitive(self, new: PrimitiveState) -> None:
        """Swap in a new primitive state; log and announce what changed (on-change telemetry)."""
        old, self.primitive = self.primitive, new
        if new is old:
            return
        if (new.kind, new.progress) != (old.kind, old.progress) or new.slot != old.slot:
            self._event("primitive", primitive=new.kind.name, progress=new.progress.name,
                        slot=new.slot, mussel_id=new.mussel_id,
                        target_x_m=round(new.target_x_m, 3), target_y_m=round(new.target_y_m, 3))
        for i, (a, b) in enumerate(zip(old.slots, new.slots, strict=True)):
            if (a.mussel_id, a.latch, a.charging) == (b.mussel_id, b.latch, b.charging):
                continue
            slot = i + 1
            self._event("slot", slot=slot, mussel_id=b.mussel_id, latch=b.latch.name, charging=b.charging)
            if a.latch == Latch.CLOSING and b.latch == Latch.OPEN:
                text = f"Dock slot {slot} aMussel {a.mussel_id} failed: out of reach"
                self._statustext(mavlink.MAV_SEVERITY_WARNING, text)
                self._event("dock_failed", slot=slot, mussel_id=a.mussel_id, reason="out of reach")
        if self.closed:
            return
        for i, s in enumerate(new.slots):
            sent = self._sent_slots[i]
            if sent is None or (sent.mussel_id, sent.latch, sent.charging) != (s.mussel_id, s.latch, s.charging):
                self._send_slot(i + 1)
        if self._primitive_key() != self._sent_primitive:
            self._send_primitive_status(self.now_us)

    def _set_mode(self, mode: int) -> None:
        if mode != self.mode:
            self._event("mode", mode=msgs.ROVER_MODE_NAMES.get(mode, str(mode)))
            self.mode = mode
            self._send_heartbeat()  # consoles show the new mode now, not up to a second later

    def _enter_hold(self) -> None:
        """HOLD mode running Hold Position: at the point already held, else where the hull is.

        A Dock or Undock in progress gives way to Hold, its latch carries on.
        """
        self._set_mode(msgs.ROVER_MODE_HOLD)
        p = self.primitive
        if p.kind != Primitive.HOLD:
            hx, hy = prim.hold_point(p, self.state.x_m, self.state.y_m)
            self._set_primitive(prim.hold(p, hx, hy))

    def _enter_guided(self) -> None:
        """GUIDED mode; with nothing to do it holds where it is until a target comes."""
        self._set_mode(msgs.ROVER_MODE_GUIDED)
        if self.primitive.kind == Primitive.IDLE:
            self._set_primitive(prim.hold(self.primitive, self.state.x_m, self.state.y_m))

    # ------------------------------------------------------------------ message handlers

    def _for_us(self, target_system: int, target_component: int) -> bool:
        return target_system in (0, self.system_id) and target_component in (0, self.component_id)

    def _on_heartbeat(self, msg: Any) -> None:
        if msg.type == mavlink.MAV_TYPE_GCS:
            self.last_gcs_heartbeat_us = self.now_us

    def _on_amussel_status(self, msg: Any) -> None:
        self.mussels.update(msg.mussel_id, msg.lat, msg.lon, msg.state)

    def _on_command_long(self, msg: Any) -> None:
        if not self._for_us(msg.target_system, msg.target_component):
            return
        params = (msg.param1, msg.param2, msg.param3, msg.param4, msg.param5, msg.param6, msg.param7)
        self._handle_command(Command(msg.command, params, None, msg.get_srcSystem(), msg.get_srcComponent()))

    def _on_command_int(self, msg: Any) -> None:
        if not self._for_us(msg.target_system, msg.target_component):
            return
        params = (msg.param1, msg.param2, msg.param3, msg.param4, float(msg.x), float(msg.y), msg.z)
        self._handle_command(Command(msg.command, params, msg.frame, msg.get_srcSystem(), msg.get_srcComponent()))

    def _on_set_mode(self, msg: Any) -> None:
        """Legacy SET_MODE message; ArduPilot answers it with a COMMAND_ACK too."""
        if msg.target_system not in (0, self.system_id):
            return
        result = self._change_mode(msg.base_mode, msg.custom_mode)
        self._send(msgs.command_ack(mavlink.MAVLINK_MSG_ID_SET_MODE, result, 0,
                                    msg.get_srcSystem(), msg.get_srcComponent()))

    def _on_mission_request_list(self, msg: Any) -> None:
        if self._for_us(msg.target_system, msg.target_component):
            self._send(mavlink.MAVLink_mission_count_message(
                msg.get_srcSystem(), msg.get_srcComponent(), 0, msg.mission_type))

    def _on_ftp(self, msg: Any) -> None:
        if self._for_us(msg.target_system, msg.target_component):
            self._send(msgs.ftp_reply(msg))

    # ------------------------------------------------------------------ PARAM protocol

    def _on_param_request_list(self, msg: Any) -> None:
        if self._for_us(msg.target_system, msg.target_component):
            for index in range(len(PARAMS)):
                self._send(msgs.param_value(index, self.params))

    def _on_param_request_read(self, msg: Any) -> None:
        if not self._for_us(msg.target_system, msg.target_component):
            return
        index = msg.param_index if msg.param_index >= 0 else INDEX.get(msg.param_id, -1)
        if 0 <= index < len(PARAMS):
            self._send(msgs.param_value(index, self.params))

    def _on_param_set(self, msg: Any) -> None:
        if not self._for_us(msg.target_system, msg.target_component):
            return
        name = msg.param_id
        index = INDEX.get(name)
        if index is None:
            self._statustext(mavlink.MAV_SEVERITY_WARNING, f"Unknown parameter {name}")
            return
        old = param_value(self.params, name)
        try:
            self.params = with_param(self.params, name, msg.param_value)
        except ParamError as exc:
            self._statustext(mavlink.MAV_SEVERITY_WARNING, str(exc))
            self._event("param_rejected", name=name, value=msg.param_value, reason=str(exc))
        else:
            new = param_value(self.params, name)
            if new != old:
                self._event("param", name=name, old=old, new=new)
        self._send(msgs.param_value(index, self.params))

    # ------------------------------------------------------------------ commands

    def _handle_command(self, cmd: Command) -> None:
        source = (cmd.source_system, cmd.source_component)
        stateful = cmd.command in STATEFUL_COMMANDS
        last = self._executed.get(source) if stateful else None
        if last is not None and last.key == cmd.key and self.now_us - last.time_us <= RETRY_WINDOW_US:
            result, param2 = last.result, last.result_param2
            self._event("command_retry", command=cmd.command, result=_result_name(result))
        else:
            handler = self._commands.get(cmd.command)
            result, param2 = handler(cmd) if handler is not None else (UNSUPPORTED, 0)
            if stateful:
                if result == ACCEPTED:
                    self._executed[source] = _Executed(cmd.key, result, param2, self.now_us)
                else:
                    self._executed.pop(source, None)
            self._event("command", command=cmd.command, name=_cmd_name(cmd.command),
                        params=[_json_float(p) for p in cmd.params], frame=cmd.frame,
                        source=list(source), result=_result_name(result), result_param2=param2)
        self._send(msgs.command_ack(cmd.command, result, param2, cmd.source_system, cmd.source_component))
        # Answers to requests go after the ACK, as ArduPilot does.
        if result == ACCEPTED and cmd.command in (
            mavlink.MAV_CMD_REQUEST_MESSAGE,
            mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES,
            mavlink.MAV_CMD_GET_HOME_POSITION,
        ):
            self._answer_request(cmd)

    def _cmd_reposition(self, cmd: Command) -> tuple[int, int]:
        if cmd.frame is not None and cmd.frame not in GLOBAL_FRAMES:
            return DENIED, 0
        lat, lon = cmd.lat_lon_deg()
        if not (math.isfinite(lat) and math.isfinite(lon) and -90 <= lat <= 90 and -180 <= lon <= 180):
            return DENIED, 0
        if lat == 0.0 and lon == 0.0:
            return DENIED, 0  # an unset position, not the Gulf of Guinea
        x, y = self.frame.to_local(lat, lon)
        x_m, y_m = float(x), float(y)
        if math.hypot(x_m, y_m) > MAX_GOTO_FROM_HOME_M:
            self._statustext(mavlink.MAV_SEVERITY_WARNING, "Go To refused: target too far from home")
            return DENIED, 0
        if self.geofence is not None and not self.geofence.contains(x_m, y_m):
            self._statustext(mavlink.MAV_SEVERITY_WARNING, "Go To refused: target outside the geofence")
            self._event("geofence", what="goto", lat_deg=lat, lon_deg=lon)
            return DENIED, 0
        speed, radius = cmd.params[0], cmd.params[2]
        speed = speed if math.isfinite(speed) and speed > 0 else self._speed_override_mps
        radius = radius if math.isfinite(radius) and radius > 0 else 0.0
        self._target_e7.remember(x_m, y_m, round(lat * 1e7), round(lon * 1e7))  # echo the target exactly
        self._set_mode(msgs.ROVER_MODE_GUIDED)
        self._set_primitive(prim.go_to(self.primitive, x_m, y_m, speed, radius))
        return ACCEPTED, 0

    def _cmd_set_mode(self, cmd: Command) -> tuple[int, int]:
        return self._change_mode(int(cmd.params[0]), int(cmd.params[1])), 0

    def _change_mode(self, base_mode: int, custom_mode: int) -> int:
        if not base_mode & mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            return DENIED
        if custom_mode == msgs.ROVER_MODE_HOLD:
            self._enter_hold()
            return ACCEPTED
        if custom_mode == msgs.ROVER_MODE_GUIDED:
            self._enter_guided()
            return ACCEPTED
        return DENIED

    def _cmd_arm(self, cmd: Command) -> tuple[int, int]:
        if cmd.params[0] not in (0.0, 1.0):
            return DENIED, 0
        armed = cmd.params[0] == 1.0
        if armed != self.armed:
            self.armed = armed
            self._event("arm" if armed else "disarm")
            self._send_heartbeat()
        return ACCEPTED, 0

    def _cmd_change_speed(self, cmd: Command) -> tuple[int, int]:
        speed = cmd.params[1]
        if speed == -1.0:  # MAVLink: no change
            return ACCEPTED, 0
        if speed == -2.0:  # MAVLink: back to the default
            speed = 0.0
        elif not (math.isfinite(speed) and speed > 0):
            return DENIED, 0
        self._speed_override_mps = speed
        self._set_primitive(prim.set_speed(self.primitive, speed))
        return ACCEPTED, 0

    def _cmd_request_message(self, cmd: Command) -> tuple[int, int]:
        msg_id = int(cmd.params[0])
        if msg_id not in self._senders:
            return DENIED, 0
        return ACCEPTED, 0

    def _cmd_request_autopilot_capabilities(self, cmd: Command) -> tuple[int, int]:
        return ACCEPTED, 0

    def _cmd_get_home_position(self, cmd: Command) -> tuple[int, int]:
        return ACCEPTED, 0

    def _answer_request(self, cmd: Command) -> None:
        if cmd.command == mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES:
            msg_id = mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION
        elif cmd.command == mavlink.MAV_CMD_GET_HOME_POSITION:
            msg_id = mavlink.MAVLINK_MSG_ID_HOME_POSITION
        else:
            msg_id = int(cmd.params[0])
        slot = int(cmd.params[1]) if cmd.command == mavlink.MAV_CMD_REQUEST_MESSAGE else 0
        if msg_id == mavlink.MAVLINK_MSG_ID_DOCK_SLOT_STATUS and 1 <= slot <= prim.N_SLOTS:
            self._send_slot(slot)  # param2 picks one slot; 0 sends all four
        else:
            self._senders[msg_id](self.now_us)

    def _cmd_set_message_interval(self, cmd: Command) -> tuple[int, int]:
        msg_id, interval = int(cmd.params[0]), cmd.params[1]
        if msg_id not in self._senders or not math.isfinite(interval) or interval < -1:
            return DENIED, 0
        if interval == -1:
            interval_us = 0
        elif interval == 0:
            interval_us = _hz_to_us(self._rates_hz[msg_id])
        else:
            interval_us = int(interval)
        self._interval_us[msg_id] = interval_us
        task = self._tasks.get(msg_id)
        if task is not None:
            self._apply_interval(msg_id, task, self.now_us)
        return ACCEPTED, 0

    def _apply_interval(self, msg_id: int, task: Task, now_us: int) -> None:
        interval_us = self._interval_us[msg_id]
        if interval_us > 0 and not self.closed and self._scheduler is not None:
            self._scheduler.reschedule(
                task, period_us=interval_us, next_us=max(now_us, min(task.next_us, now_us + interval_us)), active=True
            )
        else:
            task.active = False

    def _cmd_dock(self, cmd: Command) -> tuple[int, int]:
        slot, mussel_id = _as_int(cmd.params[0]), _as_int(cmd.params[1])
        new, refusal = prim.dock(self.primitive, slot, mussel_id, self.state.x_m, self.state.y_m,
                                 self.mussels, self.params)
        return self._slot_command_result("Dock", slot, mussel_id, new, refusal)

    def _cmd_undock(self, cmd: Command) -> tuple[int, int]:
        slot, mussel_id = _as_int(cmd.params[0]), _as_int(cmd.params[1])
        if self.geofence is not None and not self.geofence.contains(self.state.x_m, self.state.y_m):
            self._statustext(mavlink.MAV_SEVERITY_WARNING, f"Undock slot {slot} refused: not over water")
            self._event("geofence", what="undock", slot=slot)
            return DENIED, 0
        new, refusal = prim.undock(self.primitive, slot, mussel_id, self.state.x_m, self.state.y_m, self.params)
        return self._slot_command_result("Undock", slot, mussel_id, new, refusal)

    def _slot_command_result(
        self, what: str, slot: int, mussel_id: int, new: PrimitiveState, refusal: Refusal | None
    ) -> tuple[int, int]:
        if refusal is not None:
            self._statustext(mavlink.MAV_SEVERITY_WARNING,
                             f"{what} slot {slot} aMussel {mussel_id}: {REFUSAL_TEXT[refusal]}")
            return DENIED, int(refusal)
        self._set_primitive(new)
        return ACCEPTED, 0


@dataclass(frozen=True)
class Geofence:
    """The water area in the aPad's local metres; a point on the boundary is inside."""

    polygon: Any  # shapely Polygon, prepared

    @staticmethod
    def of(ring_deg: Sequence[tuple[float, float]], frame: LocalFrame) -> Geofence:
        import shapely

        if len(ring_deg) < 3:
            raise ValueError("a geofence needs at least 3 (lat, lon) vertices")
        lat = [p[0] for p in ring_deg]
        lon = [p[1] for p in ring_deg]
        x, y = frame.to_local(lat, lon)
        polygon = shapely.Polygon(list(zip(map(float, x), map(float, y), strict=True)))
        if not polygon.is_valid or polygon.area <= 0:
            raise ValueError("the geofence polygon is not a simple ring with an area")
        shapely.prepare(polygon)
        return Geofence(polygon)

    def contains(self, x_m: float, y_m: float) -> bool:
        import shapely

        return bool(shapely.intersects_xy(self.polygon, x_m, y_m))


def _hz_to_us(hz: float) -> int:
    return round(US_PER_S / hz) if hz > 0 else 0


def _as_int(value: float) -> int:
    """A command parameter that must be a whole number; -1 (refused downstream) if it is not."""
    return int(value) if math.isfinite(value) and value == int(value) else -1


def _json_float(value: float) -> float | None:
    return value if math.isfinite(value) else None


def _msg_name(msg_id: int) -> str:
    cls = mavlink.mavlink_map.get(msg_id)
    return cls.msgname if cls is not None else str(msg_id)


def _cmd_name(command: int) -> str:
    entry = mavlink.enums["MAV_CMD"].get(command)
    return entry.name if entry is not None else str(command)


def _result_name(result: int) -> str:
    entry = mavlink.enums["MAV_RESULT"].get(result)
    return entry.name.removeprefix("MAV_RESULT_") if entry is not None else str(result)
