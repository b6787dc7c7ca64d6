"""The PARAM protocol of the aPad: PARAM_REQUEST_LIST, PARAM_REQUEST_READ, PARAM_SET; and MAVLink FTP,
NAKed, so MAVProxy's parameter download falls back to PARAM_REQUEST_LIST at once.

`ApadState.params` is a frozen `ApadParams`: a PARAM_SET makes a new one (validated by `with_param`)
and swaps it in, so every model step sees one consistent set. Every PARAM_SET is answered with the
value now in force, the old one if the new was refused (with a STATUSTEXT saying why).
"""

from __future__ import annotations

from typing import Any

from apad_sitl import messages as msgs
from apad_sitl.host import PartHost
from apad_sitl.params import INDEX, PARAMS, ParamError, param_value, with_param
from apad_sitl.state import ApadState
from mavlink_dialect import mavlink


class ParamServer:
    """The vehicle's parameter part (the values themselves are `apad.params`)."""

    def __init__(self, host: PartHost, apad: ApadState) -> None:
        self._host = host
        self._apad = apad
        host.on(mavlink.MAVLINK_MSG_ID_PARAM_REQUEST_LIST, self._on_request_list)
        host.on(mavlink.MAVLINK_MSG_ID_PARAM_REQUEST_READ, self._on_request_read)
        host.on(mavlink.MAVLINK_MSG_ID_PARAM_SET, self._on_set)
        host.on(mavlink.MAVLINK_MSG_ID_FILE_TRANSFER_PROTOCOL, self._on_ftp)

    def _on_request_list(self, msg: Any) -> None:
        host, apad = self._host, self._apad
        if host.for_us(msg.target_system, msg.target_component):
            for index in range(len(PARAMS)):
                host.send(msgs.param_value(index, apad.params))

    def _on_request_read(self, msg: Any) -> None:
        host, apad = self._host, self._apad
        if not host.for_us(msg.target_system, msg.target_component):
            return
        if msg.param_index >= 0:
            index, field = msg.param_index, "param_index"
        else:
            index, field = INDEX.get(msg.param_id, -1), "param_id"
        if 0 <= index < len(PARAMS):
            host.send(msgs.param_value(index, apad.params))
        else:
            host.count_invalid("PARAM_REQUEST_READ", field)

    def _on_set(self, msg: Any) -> None:
        host, apad = self._host, self._apad
        if not host.for_us(msg.target_system, msg.target_component):
            return
        name = msg.param_id
        index = INDEX.get(name)
        if index is None:
            host.count_invalid("PARAM_SET", "param_id")
            host.statustext(mavlink.MAV_SEVERITY_WARNING, f"Unknown parameter {name}")
            return
        old = param_value(apad.params, name)
        try:
            apad.params = with_param(apad.params, name, msg.param_value)
        except ParamError as exc:
            host.count_invalid("PARAM_SET", "param_value")
            host.statustext(mavlink.MAV_SEVERITY_WARNING, str(exc))
            host.event("param_rejected", name=name, value=_json_float(msg.param_value), reason=str(exc))
        else:
            new = param_value(apad.params, name)
            if new != old:
                host.event("param", name=name, old=old, new=new)
        host.send(msgs.param_value(index, apad.params))

    def _on_ftp(self, msg: Any) -> None:
        host = self._host
        if host.for_us(msg.target_system, msg.target_component):
            host.send(msgs.ftp_reply(msg))


def _json_float(value: float) -> float | str:
    """Strict JSON has no NaN or infinity: those go in the event log as text."""
    return value if value - value == 0.0 else str(value)
