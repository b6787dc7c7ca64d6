"""What the GCS reads from MAVLink, typed and validated once, at the edge.

`read(msg)` turns one decoded message into one typed record, or a `Rejected` naming the field
that failed (counted by the router, the message dropped). The registry, the API, the mission loop
and the console read records, never a pymavlink message (the local parties the router serves, such
as the simulated fleet, speak MAVLink themselves and get the message).
Only what the GCS uses is read; other messages give None (not an error, not counted).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, NamedTuple

from apad_sitl.vocabulary import N_SLOTS, Latch, Primitive, Progress
from mavlink_dialect import mavlink
from mussel_sim.vocabulary import MusselState

GCS_SYSTEM_ID = 250  # this GCS's MAVLink system
GCS_COMPONENT_ID = mavlink.MAV_COMP_ID_MISSIONPLANNER
DEG_E7 = 10_000_000
MAX_TIME_US = 2**63 - 1  # a uint64 on the wire; past this it is no time (and no int64 holds it)
UNKNOWN_U16 = 0xFFFF  # MAVLink's "unknown" for voltages and headings
_RESULTS = frozenset(mavlink.enums["MAV_RESULT"]) - {max(mavlink.enums["MAV_RESULT"])}  # minus *_ENUM_END
_STATES = frozenset(int(s) for s in MusselState)
_PRIMITIVES = frozenset(int(p) for p in Primitive)
_PROGRESS = frozenset(int(p) for p in Progress)
_LATCHES = frozenset(int(latch) for latch in Latch)
# Heartbeats of these types are not vehicles we command (ground stations, companion computers).
NOT_VEHICLES = frozenset({mavlink.MAV_TYPE_GCS, mavlink.MAV_TYPE_ONBOARD_CONTROLLER})


class Location(NamedTuple):
    lat: float  # deg, WGS84
    lon: float  # deg, WGS84


@dataclass(frozen=True, slots=True)
class Rejected:
    """A message that failed validation: `reason` is MESSAGE.field (the drop counter's key)."""

    reason: str


@dataclass(frozen=True, slots=True)
class Heartbeat:
    custom_mode: int
    armed: bool


@dataclass(frozen=True, slots=True)
class Position:
    lat_deg: float
    lon_deg: float
    heading_deg: float | None  # None: the vehicle does not know


@dataclass(frozen=True, slots=True)
class PrimitiveView:
    """The aPad's PRIMITIVE_STATUS."""

    primitive: Primitive = Primitive.IDLE
    progress: Progress = Progress.NONE
    target_lat_e7: int = 0
    target_lon_e7: int = 0
    distance_to_go_m: float = 0.0
    distance_travelled_m: float = 0.0
    slot: int = 0
    mussel_id: int = 0
    time_us: int = 0


@dataclass(frozen=True, slots=True)
class SlotView:
    """One docking slot as the aPad reports it (DOCK_SLOT_STATUS)."""

    slot: int
    mussel_id: int = 0  # 0: empty
    latch: Latch = Latch.OPEN
    charging: bool = False

    @property
    def free(self) -> bool:
        """Open and empty: a Dock may use it (the one free-slot rule)."""
        return self.latch == Latch.OPEN and self.mussel_id == 0


@dataclass(frozen=True, slots=True)
class Battery:
    voltage_v: float | None  # None: unknown
    remaining_pct: int  # -1: unknown


@dataclass(frozen=True, slots=True)
class Charging:
    """BATTERY_STATUS.charge_state: whether the aPad charges (at its home charger)."""

    charging: bool


@dataclass(frozen=True, slots=True)
class Home:
    lat_deg: float
    lon_deg: float


@dataclass(frozen=True, slots=True)
class ParamValue:
    name: str
    value: float


@dataclass(frozen=True, slots=True)
class StatusText:
    severity: int
    text: str


@dataclass(frozen=True, slots=True)
class CommandAck:
    command: int
    result: int
    result_param2: int
    target_system: int  # the GCS it answers (0: any)


@dataclass(frozen=True, slots=True)
class MusselView:
    """One AMUSSEL_STATUS (simulated or real): what the GCS knows of an aMussel."""

    mussel_id: int
    lat_e7: int
    lon_e7: int
    depth_m: float
    battery_frac: float
    battery_mv: int
    state: MusselState
    simulated: bool
    time_us: int

    @property
    def location(self) -> Location:
        return Location(self.lat_e7 / DEG_E7, self.lon_e7 / DEG_E7)


@dataclass(frozen=True, slots=True)
class GoToSent:
    """A Go To (DO_REPOSITION as COMMAND_INT) the GCS sent to aPad `target_system`."""

    target_system: int
    lat_e7: int
    lon_e7: int


Record = (Heartbeat | Position | PrimitiveView | SlotView | Battery | Charging | Home | ParamValue | StatusText
          | CommandAck | MusselView | GoToSent)


def lat_lon_ok(lat_e7: int, lon_e7: int) -> bool:
    return -90 * DEG_E7 <= lat_e7 <= 90 * DEG_E7 and -180 * DEG_E7 <= lon_e7 <= 180 * DEG_E7


def _finite(*values: float) -> bool:
    return all(math.isfinite(v) for v in values)


def read(msg: Any) -> Record | Rejected | None:
    """The typed record of `msg`, a `Rejected`, or None for messages the GCS does not use."""
    reader = _READERS.get(msg.get_msgId())
    return None if reader is None else reader(msg)


def _heartbeat(m: Any) -> Heartbeat | None:
    # A vehicle's mode is its autopilot's: a camera's or gimbal's heartbeat of the same system is not.
    if m.type in NOT_VEHICLES or m.get_srcComponent() != mavlink.MAV_COMP_ID_AUTOPILOT1:
        return None
    return Heartbeat(int(m.custom_mode), bool(m.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED))


def _position(m: Any) -> Position | Rejected:
    if not lat_lon_ok(m.lat, m.lon):
        return Rejected("GLOBAL_POSITION_INT.lat_lon")
    if m.hdg != UNKNOWN_U16 and m.hdg >= 36000:
        return Rejected("GLOBAL_POSITION_INT.hdg")
    return Position(m.lat / DEG_E7, m.lon / DEG_E7, None if m.hdg == UNKNOWN_U16 else m.hdg / 100.0)


def _primitive(m: Any) -> PrimitiveView | Rejected:
    if m.primitive not in _PRIMITIVES:
        return Rejected("PRIMITIVE_STATUS.primitive")
    if m.progress not in _PROGRESS:
        return Rejected("PRIMITIVE_STATUS.progress")
    if not (_finite(m.distance_to_go, m.distance_travelled) and m.distance_to_go >= 0 and m.distance_travelled >= 0):
        return Rejected("PRIMITIVE_STATUS.distance")
    if not 0 <= m.slot <= N_SLOTS:
        return Rejected("PRIMITIVE_STATUS.slot")
    if (m.target_lat, m.target_lon) != (0, 0) and not lat_lon_ok(m.target_lat, m.target_lon):
        return Rejected("PRIMITIVE_STATUS.target")
    return PrimitiveView(Primitive(m.primitive), Progress(m.progress), m.target_lat, m.target_lon,
                         m.distance_to_go, m.distance_travelled, m.slot, m.mussel_id, m.time_us)


def _slot(m: Any) -> SlotView | Rejected:
    if not 1 <= m.slot <= N_SLOTS:
        return Rejected("DOCK_SLOT_STATUS.slot")
    if m.latch not in _LATCHES:
        return Rejected("DOCK_SLOT_STATUS.latch")
    if m.charging not in (0, 1):
        return Rejected("DOCK_SLOT_STATUS.charging")
    return SlotView(m.slot, m.mussel_id, Latch(m.latch), bool(m.charging))


def _sys_status(m: Any) -> Battery | Rejected:
    if not -1 <= m.battery_remaining <= 100:
        return Rejected("SYS_STATUS.battery_remaining")
    volts = None if m.voltage_battery == UNKNOWN_U16 else m.voltage_battery / 1000.0
    return Battery(volts, m.battery_remaining)


def _battery_status(m: Any) -> Charging | Rejected:
    if not 0 <= m.charge_state <= mavlink.MAV_BATTERY_CHARGE_STATE_CHARGING:
        return Rejected("BATTERY_STATUS.charge_state")
    return Charging(m.charge_state == mavlink.MAV_BATTERY_CHARGE_STATE_CHARGING)


def _home(m: Any) -> Home | Rejected:
    if not lat_lon_ok(m.latitude, m.longitude):
        return Rejected("HOME_POSITION.lat_lon")
    return Home(m.latitude / DEG_E7, m.longitude / DEG_E7)


def _param_value(m: Any) -> ParamValue | Rejected:
    name = m.param_id if isinstance(m.param_id, str) else bytes(m.param_id).decode("ascii", "replace")
    if not name:
        return Rejected("PARAM_VALUE.param_id")
    if not _finite(m.param_value):
        return Rejected("PARAM_VALUE.value")
    return ParamValue(name, float(m.param_value))


def _statustext(m: Any) -> StatusText | Rejected:
    if m.severity > mavlink.MAV_SEVERITY_DEBUG:
        return Rejected("STATUSTEXT.severity")
    text = m.text if isinstance(m.text, str) else bytes(m.text).decode("utf-8", "replace")
    return StatusText(int(m.severity), text.rstrip("\0"))


def _ack(m: Any) -> CommandAck | Rejected:
    if m.result not in _RESULTS:
        return Rejected("COMMAND_ACK.result")
    return CommandAck(int(m.command), int(m.result), int(getattr(m, "result_param2", 0)),
                      int(getattr(m, "target_system", 0)))


def _mussel(m: Any) -> MusselView | Rejected:
    if m.mussel_id == 0:
        return Rejected("AMUSSEL_STATUS.mussel_id")
    if not lat_lon_ok(m.lat, m.lon):
        return Rejected("AMUSSEL_STATUS.lat_lon")
    if not (_finite(m.depth, m.battery) and 0.0 <= m.battery <= 1.0 and m.depth >= 0.0):
        return Rejected("AMUSSEL_STATUS.battery_depth")
    if m.state not in _STATES:
        return Rejected("AMUSSEL_STATUS.state")
    if m.simulated not in (0, 1):
        return Rejected("AMUSSEL_STATUS.simulated")
    if not 0 <= m.time_us <= MAX_TIME_US:
        return Rejected("AMUSSEL_STATUS.time_us")
    return MusselView(m.mussel_id, m.lat, m.lon, m.depth, m.battery, m.battery_voltage, MusselState(m.state),
                        bool(m.simulated), m.time_us)


def _command_int(m: Any) -> GoToSent | None:
    if m.command != mavlink.MAV_CMD_DO_REPOSITION or not lat_lon_ok(m.x, m.y):
        return None
    return GoToSent(m.target_system, m.x, m.y)


_READERS = {
    mavlink.MAVLINK_MSG_ID_HEARTBEAT: _heartbeat,
    mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: _position,
    mavlink.MAVLINK_MSG_ID_PRIMITIVE_STATUS: _primitive,
    mavlink.MAVLINK_MSG_ID_DOCK_SLOT_STATUS: _slot,
    mavlink.MAVLINK_MSG_ID_SYS_STATUS: _sys_status,
    mavlink.MAVLINK_MSG_ID_BATTERY_STATUS: _battery_status,
    mavlink.MAVLINK_MSG_ID_HOME_POSITION: _home,
    mavlink.MAVLINK_MSG_ID_PARAM_VALUE: _param_value,
    mavlink.MAVLINK_MSG_ID_STATUSTEXT: _statustext,
    mavlink.MAVLINK_MSG_ID_COMMAND_ACK: _ack,
    mavlink.MAVLINK_MSG_ID_AMUSSEL_STATUS: _mussel,
    mavlink.MAVLINK_MSG_ID_COMMAND_INT: _command_int,
}
