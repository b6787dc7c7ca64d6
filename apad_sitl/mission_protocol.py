"""The mission protocol, as far as the aPad has one: it runs primitives, not missions, so a GCS
asking for its mission list (every stock GCS does on connect) hears that it is empty."""

from __future__ import annotations

from typing import Any

from apad_sitl.host import PartHost
from mavlink_dialect import mavlink

MISSION_TYPES = frozenset(mavlink.enums["MAV_MISSION_TYPE"]) - {mavlink.MAV_MISSION_TYPE_ENUM_END}


class MissionProtocol:
    def __init__(self, host: PartHost) -> None:
        self._host = host
        host.on(mavlink.MAVLINK_MSG_ID_MISSION_REQUEST_LIST, self._on_request_list)

    def _on_request_list(self, msg: Any) -> None:
        host = self._host
        if not host.for_us(msg.target_system, msg.target_component):
            return
        if msg.mission_type not in MISSION_TYPES:
            host.count_invalid("MISSION_REQUEST_LIST", "mission_type")
            return
        host.send(mavlink.MAVLink_mission_count_message(msg.get_srcSystem(), msg.get_srcComponent(), 0,
                                                        msg.mission_type))
