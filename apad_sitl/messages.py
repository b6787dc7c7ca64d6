"""MAVLink messages of the SITL aPad, built from model state. Pure: state in, message out.

What ArduRover sends is the reference, so stock clients (MAVSDK, MAVProxy) read us as a boat:
ArduRover's custom modes (`vocabulary.RoverMode`), SYS_STATUS health bits with PREARM_CHECK (MAVSDK's
"armable"), battery in SYS_STATUS and BATTERY_STATUS. Frames: GLOBAL_POSITION_INT velocities are
NED (vx north, vy east), the models' are east/north.
"""

from __future__ import annotations

import math
from typing import Any, cast

from apad_sitl.energy_counters import EnergyCounters
from apad_sitl.params import PARAMS, ApadParams
from apad_sitl.primitives import PrimitiveState, SlotState
from apad_sitl.vehicle import BATTERY_EMPTY_V, VehicleState, wrap_pi
from apad_sitl.vocabulary import Primitive
from mavlink_dialect import mavlink

# Sensors a real aPad has and reports healthy (GPS, IMU, compass, thrusters, battery, position
# control); PREARM_CHECK healthy is what MAVSDK's health.is_armable reads.
SENSORS = (
    mavlink.MAV_SYS_STATUS_SENSOR_3D_GYRO
    | mavlink.MAV_SYS_STATUS_SENSOR_3D_ACCEL
    | mavlink.MAV_SYS_STATUS_SENSOR_3D_MAG
    | mavlink.MAV_SYS_STATUS_SENSOR_GPS
    | mavlink.MAV_SYS_STATUS_SENSOR_YAW_POSITION
    | mavlink.MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL
    | mavlink.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS
    | mavlink.MAV_SYS_STATUS_AHRS
    | mavlink.MAV_SYS_STATUS_SENSOR_BATTERY
    | mavlink.MAV_SYS_STATUS_PREARM_CHECK
)
CAPABILITIES = (
    mavlink.MAV_PROTOCOL_CAPABILITY_MAVLINK2
    | mavlink.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
    | mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
    | mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_C_CAST
)
FLIGHT_SW_VERSION = (0 << 24) | (1 << 16) | (0 << 8) | mavlink.FIRMWARE_VERSION_TYPE_DEV  # 0.1.0-dev
UINT16_MAX = 0xFFFF
INT16_MAX = 0x7FFF

# MAVLink FTP (the FILE_TRANSFER_PROTOCOL payload): we serve no files.
FTP_OP_TERMINATE_SESSION = 1
FTP_OP_RESET_SESSIONS = 2
FTP_OP_ACK = 128
FTP_OP_NAK = 129
FTP_ERR_UNKNOWN_COMMAND = 7
FTP_ERR_FILE_NOT_FOUND = 10
FTP_PATH_OPS = frozenset({3, 4, 6, 8, 9, 10, 11, 12, 13, 14})  # list, open, create, remove, ...
FTP_PAYLOAD_LEN = 251


def time_boot_ms(now_us: int) -> int:
    return (now_us // 1000) & 0xFFFFFFFF


def heartbeat(mode: int, armed: bool) -> mavlink.MAVLink_message:
    """`mode` is the custom mode, a `RoverMode`."""
    base_mode = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    if armed:
        base_mode |= mavlink.MAV_MODE_FLAG_SAFETY_ARMED
    return mavlink.MAVLink_heartbeat_message(
        mavlink.MAV_TYPE_SURFACE_BOAT,
        mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA,
        base_mode,
        mode,
        mavlink.MAV_STATE_ACTIVE if armed else mavlink.MAV_STATE_STANDBY,
        3,
    )


def global_position_int(now_us: int, lat_e7: int, lon_e7: int, v: VehicleState) -> mavlink.MAVLink_message:
    hdg_cdeg = round(math.degrees(v.heading_rad) * 100.0) % 36000
    return mavlink.MAVLink_global_position_int_message(
        time_boot_ms(now_us), lat_e7, lon_e7, 0, 0,
        round(v.vy_mps * 100.0), round(v.vx_mps * 100.0), 0, hdg_cdeg,
    )


def _battery_pct(v: VehicleState) -> int:
    return max(0, min(100, round(v.battery_frac * 100.0)))


def sys_status(v: VehicleState) -> mavlink.MAVLink_message:
    health = SENSORS if v.battery_v > BATTERY_EMPTY_V else SENSORS & ~mavlink.MAV_SYS_STATUS_SENSOR_BATTERY
    return mavlink.MAVLink_sys_status_message(
        SENSORS, SENSORS, health, 0, round(v.battery_v * 1000.0), -1, _battery_pct(v), 0, 0, 0, 0, 0, 0
    )


def battery_status(v: VehicleState, energy: EnergyCounters) -> mavlink.MAVLink_message:
    # Cell voltages unknown: the pack voltage goes in cell 0, the rest UINT16_MAX (MAVLink's rule).
    # charge_state: CHARGING at its home charger (energy passed to aMussels: the event log, result.json).
    voltages = [round(v.battery_v * 1000.0)] + [UINT16_MAX] * 9
    state = mavlink.MAV_BATTERY_CHARGE_STATE_CHARGING if energy.charging else mavlink.MAV_BATTERY_CHARGE_STATE_OK
    return mavlink.MAVLink_battery_status_message(
        0, mavlink.MAV_BATTERY_FUNCTION_ALL, mavlink.MAV_BATTERY_TYPE_LIPO, INT16_MAX, voltages,
        -1, -1, -1, _battery_pct(v), 0, state,
    )


def attitude(now_us: int, v: VehicleState) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_attitude_message(
        time_boot_ms(now_us), 0.0, 0.0, wrap_pi(v.heading_rad), 0.0, 0.0, v.yaw_rate_radps
    )


def vfr_hud(v: VehicleState, params: ApadParams) -> mavlink.MAVLink_message:
    full_thrust = params.accel_max_mps2 + params.drag_per_s * params.speed_max_mps
    throttle = round(min(100.0, 100.0 * v.thrust_mps2 / full_thrust)) if full_thrust > 0 else 0
    return mavlink.MAVLink_vfr_hud_message(
        math.hypot(v.water_vx_mps, v.water_vy_mps), v.ground_speed_mps,
        round(math.degrees(v.heading_rad)) % 360, throttle, 0.0, 0.0,
    )


def extended_sys_state() -> mavlink.MAVLink_message:
    return mavlink.MAVLink_extended_sys_state_message(
        mavlink.MAV_VTOL_STATE_UNDEFINED, mavlink.MAV_LANDED_STATE_UNDEFINED
    )


def home_position(now_us: int, lat_e7: int, lon_e7: int) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_home_position_message(
        lat_e7, lon_e7, 0, 0.0, 0.0, 0.0, [1.0, 0.0, 0.0, 0.0], 0.0, 0.0, 0.0, now_us
    )


def autopilot_version(system_id: int) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_autopilot_version_message(
        CAPABILITIES, FLIGHT_SW_VERSION, 0, 0, 0, [0] * 8, [0] * 8, [0] * 8, 0, 0, system_id
    )


def primitive_status(
    now_us: int, prim: PrimitiveState, target_lat_e7: int, target_lon_e7: int, v: VehicleState
) -> mavlink.MAVLink_message:
    idle = prim.kind == Primitive.IDLE
    distance_to_go = 0.0 if idle else math.hypot(prim.target_x_m - v.x_m, prim.target_y_m - v.y_m)
    return mavlink.MAVLink_primitive_status_message(
        now_us, int(prim.kind), int(prim.progress), target_lat_e7, target_lon_e7,
        distance_to_go, v.distance_travelled_m, prim.slot, prim.mussel_id,
    )


def dock_slot_status(now_us: int, slot: int, s: SlotState) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_dock_slot_status_message(now_us, slot, s.mussel_id, int(s.latch), int(s.charging))


def param_value(index: int, params: ApadParams) -> mavlink.MAVLink_message:
    spec = PARAMS[index]
    value = float(getattr(params, spec.field))
    ptype = mavlink.MAV_PARAM_TYPE_INT32 if spec.integral else mavlink.MAV_PARAM_TYPE_REAL32
    return mavlink.MAVLink_param_value_message(spec.name.encode("ascii"), value, ptype, len(PARAMS), index)


def statustext(severity: int, text: str) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_statustext_message(severity, text.encode("utf-8")[:50])


def command_ack(
    command: int, result: int, result_param2: int, target_system: int, target_component: int
) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_command_ack_message(command, result, 0, result_param2, target_system, target_component)


def ftp_reply(request: mavlink.MAVLink_message) -> mavlink.MAVLink_message:
    """The answer to any MAVLink-FTP request: ACK session resets, NAK everything else.

    A NAK lets MAVProxy fall back to PARAM_REQUEST_LIST at once instead of timing out.
    """
    payload = bytes(cast(Any, request).payload)  # FILE_TRANSFER_PROTOCOL's; the stub types the base class
    seq = payload[0] | (payload[1] << 8)
    session, opcode = payload[2], payload[3]
    if opcode in (FTP_OP_TERMINATE_SESSION, FTP_OP_RESET_SESSIONS):
        reply_op, data = FTP_OP_ACK, b""
    else:
        err = FTP_ERR_FILE_NOT_FOUND if opcode in FTP_PATH_OPS else FTP_ERR_UNKNOWN_COMMAND
        reply_op, data = FTP_OP_NAK, bytes([err])
    seq = (seq + 1) & 0xFFFF
    header = bytes([seq & 0xFF, seq >> 8, session, reply_op, len(data), opcode, 0, 0]) + payload[8:12]
    body = header + data
    return mavlink.MAVLink_file_transfer_protocol_message(
        0, request.get_srcSystem(), request.get_srcComponent(), list(body.ljust(FTP_PAYLOAD_LEN, b"\0"))
    )
