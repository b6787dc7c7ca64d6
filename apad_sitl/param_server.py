"""The PARAM protocol of the aPad: PARAM_REQUEST_LIST, PARAM_REQUEST_READ, PARAM_SET; and MAVLink FTP,
NAKed, so MAVProxy's parameter download falls back to PARAM_REQUEST_LIST at once.

`vehicle.params` is a frozen `ApadParams`: a PARAM_SET makes a new one (validated by `with_param`)
and swaps it in, so every model step sees one consistent set. Every PARAM_SET is answered with the
value now in force, the old one if the new was refused (with a STATUSTEXT saying why).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from apad_sitl import messages as msgs
from apad_sitl.params import INDEX, PARAMS, ParamError, param_value, with_param
from mavlink_dialect import mavlink

if TYPE_CHECKING:
    from apad_sitl.endpoint import SitlVehicle


class ParamServer:
    """The vehicle's parameter part (the values themselves are `vehicle.params`)."""

    def __init__(self, vehicle: SitlVehicle) -> None:
        self._v = vehicle
        vehicle.on(mavlink.MAVLINK_MSG_ID_PARAM_REQUEST_LIST, self._on_request_list)
        vehicle.on(mavlink.MAVLINK_MSG_ID_PARAM_REQUEST_READ, self._on_request_read)
        vehicle.on(mavlink.MAVLINK_MSG_ID_PARAM_SET, self._on_set)
        vehicle.on(mavlink.MAVLINK_MSG_ID_FILE_TRANSFER_PROTOCOL, self._on_ftp)

    def _on_request_list(self, msg: Any) -> None:
        v = self._v
        if v.for_us(msg.target_system, msg.target_component):
            for index in range(len(PARAMS)):
                v.send(msgs.param_value(index, v.params))

    def _on_request_read(self, msg: Any) -> None:
        v = self._v
        if not v.for_us(msg.target_system, msg.target_component):
            return
        if msg.param_index >= 0:
            index, field = msg.param_index, "param_index"
        else:
            index, field = INDEX.get(msg.param_id, -1), "param_id"
        if 0 <= index < len(PARAMS):
            v.send(msgs.param_value(index, v.params))
        else:
            v.count_invalid("PARAM_REQUEST_READ", field)

    def _on_set(self, msg: Any) -> None:
        v = self._v
        if not v.for_us(msg.target_system, msg.target_component):
            return
        name = msg.param_id
        index = INDEX.get(name)
        if index is None:
            v.count_invalid("PARAM_SET", "param_id")
            v.statustext(mavlink.MAV_SEVERITY_WARNING, f"Unknown parameter {name}")
            return
        old = param_value(v.params, name)
        try:
            v.params = with_param(v.params, name, msg.param_value)
        except ParamError as exc:
            v.count_invalid("PARAM_SET", "param_value")
            v.statustext(mavlink.MAV_SEVERITY_WARNING, str(exc))
            v.event("param_rejected", name=name, value=_json_float(msg.param_value), reason=str(exc))
        else:
            new = param_value(v.params, name)
            if new != old:
                v.event("param", name=name, old=old, new=new)
        v.send(msgs.param_value(index, v.params))

    def _on_ftp(self, msg: Any) -> None:
        v = self._v
        if v.for_us(msg.target_system, msg.target_component):
            v.send(msgs.ftp_reply(msg))


def _json_float(value: float) -> float | str:
    """Strict JSON has no NaN or infinity: those go in the event log as text."""
    return value if value - value == 0.0 else str(value)
