"""The mission protocol, as far as the aPad has one: it runs primitives, not missions, so a GCS
asking for its mission list (every stock GCS does on connect) hears that it is empty."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from mavlink_dialect import mavlink

if TYPE_CHECKING:
    from apad_sitl.endpoint import SitlVehicle

MISSION_TYPES = frozenset(mavlink.enums["MAV_MISSION_TYPE"]) - {mavlink.MAV_MISSION_TYPE_ENUM_END}


class MissionProtocol:
    def __init__(self, vehicle: SitlVehicle) -> None:
        self._v = vehicle
        vehicle.on(mavlink.MAVLINK_MSG_ID_MISSION_REQUEST_LIST, self._on_request_list)

    def _on_request_list(self, msg: Any) -> None:
        v = self._v
        if not v.for_us(msg.target_system, msg.target_component):
            return
        if msg.mission_type not in MISSION_TYPES:
            v.count_invalid("MISSION_REQUEST_LIST", "mission_type")
            return
        v.send(mavlink.MAVLink_mission_count_message(msg.get_srcSystem(), msg.get_srcComponent(), 0, msg.mission_type))
