"""The PARAM protocol alone: `ParamServer` on a recording host and an `ApadState`; no vehicle.

The list and single reads, PARAM_SET swapping in a new validated `ApadParams` (the refused value
answered with the one in force), unknown names counted, and MAVLink FTP NAKed.
"""

from __future__ import annotations

import pytest
from test_sitl_part_host import GCS, SYSID, RecordingHost

from apad_sitl.param_server import ParamServer
from apad_sitl.params import INDEX, PARAMS, ApadParams
from apad_sitl.state import ApadState
from mavlink_dialect import mavlink

REAL32 = mavlink.MAV_PARAM_TYPE_REAL32


class Bench:
    def __init__(self) -> None:
        self.host = RecordingHost()
        self.apad = ApadState(ApadParams())
        self.server = ParamServer(self.host, self.apad)

    def set(self, name: str, value: float, target: int = SYSID) -> None:
        self.host.receive(mavlink.MAVLink_param_set_message(target, 0, name.encode(), value, REAL32))


@pytest.fixture
def b() -> Bench:
    return Bench()


def test_the_list_is_every_parameter_in_order_with_its_value(b: Bench) -> None:
    b.host.receive(mavlink.MAVLink_param_request_list_message(SYSID, 0))
    sent = b.host.take()
    assert [(m.param_id, m.param_index, m.param_count) for m in sent] == [
        (spec.name, i, len(PARAMS)) for i, spec in enumerate(PARAMS)]
    assert sent[INDEX["SPEED_MAX"]].param_value == 0.5
    assert sent[INDEX["FS_GCS_ENABLE"]].param_type == mavlink.MAV_PARAM_TYPE_INT32


def test_a_read_by_name_or_index_and_a_read_of_nothing(b: Bench) -> None:
    b.host.receive(mavlink.MAVLink_param_request_read_message(SYSID, 0, b"DOCK_REACH", -1))
    b.host.receive(mavlink.MAVLink_param_request_read_message(SYSID, 0, b"", INDEX["HOLD_KD"]))
    b.host.receive(mavlink.MAVLink_param_request_read_message(SYSID, 0, b"NO_SUCH", -1))
    b.host.receive(mavlink.MAVLink_param_request_read_message(SYSID, 0, b"", len(PARAMS)))
    assert [(m.param_id, m.param_value) for m in b.host.take()] == [("DOCK_REACH", 2.0), ("HOLD_KD", 0.5)]
    assert b.host.dropped == {"invalid:PARAM_REQUEST_READ:param_id": 1, "invalid:PARAM_REQUEST_READ:param_index": 1}


def test_a_set_swaps_in_new_params_and_is_answered_with_the_value_in_force(b: Bench) -> None:
    before = b.apad.params
    b.set("SPEED_MAX", 1.25)
    assert b.apad.params.speed_max_mps == 1.25 and b.apad.params is not before
    assert [(m.param_id, m.param_value) for m in b.host.take()] == [("SPEED_MAX", 1.25)]
    assert b.host.events == [("param", {"name": "SPEED_MAX", "old": 0.5, "new": 1.25})]


def test_a_value_out_of_range_is_refused_and_the_old_one_answered(b: Bench) -> None:
    b.set("SPEED_MAX", 9.0)
    text, value = b.host.take()  # why, then the value in force
    assert (value.param_id, value.param_value) == ("SPEED_MAX", 0.5)
    assert text.get_type() == "STATUSTEXT" and "SPEED_MAX" in text.text
    assert b.apad.params == ApadParams()
    assert b.host.dropped == {"invalid:PARAM_SET:param_value": 1}
    assert [name for name, _ in b.host.events] == ["param_rejected"]


def test_an_unknown_name_is_counted_and_not_answered_with_a_value(b: Bench) -> None:
    b.set("NO_SUCH", 1.0)
    assert [(m.get_type(), m.text) for m in b.host.take()] == [("STATUSTEXT", "Unknown parameter NO_SUCH")]
    assert b.host.dropped == {"invalid:PARAM_SET:param_id": 1}


def test_another_systems_parameters_are_not_ours(b: Bench) -> None:
    b.set("SPEED_MAX", 1.0, target=SYSID + 1)
    b.host.receive(mavlink.MAVLink_param_request_list_message(SYSID + 1, 0))
    assert (b.host.take(), b.apad.params, b.host.dropped) == ([], ApadParams(), {})


def test_ftp_is_naked_so_a_client_falls_back_to_the_param_list(b: Bench) -> None:
    payload = [0] * 251
    payload[3] = 4  # OpenFileRO
    b.host.receive(mavlink.MAVLink_file_transfer_protocol_message(0, SYSID, 0, payload))
    (reply,) = b.host.take()
    assert (reply.get_type(), reply.target_system, reply.target_component) == ("FILE_TRANSFER_PROTOCOL", *GCS)
    assert (reply.payload[3], reply.payload[5]) == (129, 4)  # NAK of OpenFileRO
