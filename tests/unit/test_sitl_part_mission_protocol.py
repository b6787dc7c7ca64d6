"""The mission protocol alone: `MissionProtocol` on a recording host, nothing else.

A GCS asking for the mission list (every stock GCS does on connect) hears that it is empty, for
the mission type it asked about; a type that is none is counted and not answered.
"""

from __future__ import annotations

from test_sitl_part_host import COMPID, GCS, SYSID, RecordingHost

from apad_sitl.mission_protocol import MissionProtocol
from mavlink_dialect import mavlink


def test_the_mission_list_is_empty_for_every_mission_type() -> None:
    host = RecordingHost()
    MissionProtocol(host)
    host.receive(mavlink.MAVLink_mission_request_list_message(SYSID, COMPID, mavlink.MAV_MISSION_TYPE_MISSION))
    host.receive(mavlink.MAVLink_mission_request_list_message(0, 0, mavlink.MAV_MISSION_TYPE_FENCE))
    assert [(m.get_type(), m.count, m.mission_type, m.target_system, m.target_component) for m in host.take()] == [
        ("MISSION_COUNT", 0, mavlink.MAV_MISSION_TYPE_MISSION, *GCS),
        ("MISSION_COUNT", 0, mavlink.MAV_MISSION_TYPE_FENCE, *GCS),
    ]


def test_a_request_for_another_vehicle_or_of_no_mission_type_is_not_answered() -> None:
    host = RecordingHost()
    MissionProtocol(host)
    host.receive(mavlink.MAVLink_mission_request_list_message(SYSID + 1, 0, mavlink.MAV_MISSION_TYPE_MISSION))
    host.receive(mavlink.MAVLink_mission_request_list_message(SYSID, COMPID + 1, mavlink.MAV_MISSION_TYPE_MISSION))
    host.receive(mavlink.MAVLink_mission_request_list_message(SYSID, 0, 77))
    assert host.take() == []
    assert host.dropped == {"invalid:MISSION_REQUEST_LIST:mission_type": 1}
