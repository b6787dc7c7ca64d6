"""The command table alone: a `CommandTable` on a recording host and an `ApadState`, no vehicle.

COMMAND_LONG and COMMAND_INT in as real frames; one COMMAND_ACK out per command; unknown commands
UNSUPPORTED and counted; invalid fields DENIED and counted; a retransmission (the same frame again,
or the same command while its effect still holds) answered and not executed again.
"""

from __future__ import annotations

from typing import Any

import pytest
from test_sitl_part_host import GCS, SYSID, RecordingHost

from apad_sitl import primitives as prim
from apad_sitl.command_handler import CommandTable
from apad_sitl.host import ACCEPT, ACCEPTED, DENIED, UNSUPPORTED, Command, Reply, invalid, whole
from apad_sitl.params import ApadParams
from apad_sitl.state import ApadState
from mavlink_dialect import mavlink

GOTO = mavlink.MAV_CMD_DO_REPOSITION
PING = mavlink.MAV_CMD_REQUEST_MESSAGE


class Table:
    """A command table with one stateful command (a Go To to param5, param6) and one request."""

    def __init__(self) -> None:
        self.host = RecordingHost()
        self.apad = ApadState(ApadParams())
        self.table = CommandTable(self.host, self.apad)
        self.executed: list[Command] = []
        self.table.register(GOTO, self._goto, stateful=True)
        self.table.register(PING, self._request)

    def _goto(self, cmd: Command) -> Reply:
        self.executed.append(cmd)
        self.apad.set_primitive(prim.go_to(self.apad.primitive, cmd.params[4], cmd.params[5]))
        return ACCEPT

    def _request(self, cmd: Command) -> Reply:
        self.executed.append(cmd)
        n = whole(cmd.params[0], 0, 100)
        if n is None:
            return invalid(cmd.field(1))
        return Reply(ACCEPTED, then=lambda: self.host.statustext(mavlink.MAV_SEVERITY_INFO, f"asked {n}"))


def long(command: int, *params: float, target: int = SYSID) -> Any:
    p = (*params, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)[:7]
    return mavlink.MAVLink_command_long_message(target, 0, command, 0, *p)


@pytest.fixture
def t() -> Table:
    return Table()


def test_a_command_for_us_runs_its_handler_and_is_acked_to_its_source(t: Table) -> None:
    t.host.receive(long(GOTO, 0, 0, 0, 0, 10.0, 5.0))
    assert [(c.command, c.params[4:6], c.frame, (c.source_system, c.source_component)) for c in t.executed] == [
        (GOTO, (10.0, 5.0), None, GCS)]
    (ack,) = t.host.take()
    assert (ack.get_type(), ack.command, ack.result, ack.target_system, ack.target_component) == (
        "COMMAND_ACK", GOTO, ACCEPTED, *GCS)
    name, fields = t.host.events[-1]
    assert (name, fields["name"], fields["result"], fields["source"]) == (
        "command", "MAV_CMD_DO_REPOSITION", "ACCEPTED", list(GCS))


def test_a_command_for_another_system_is_not_answered(t: Table) -> None:
    t.host.receive(long(GOTO, 0, 0, 0, 0, 10.0, 5.0, target=9))
    assert (t.executed, t.host.take(), t.host.events) == ([], [], [])


def test_an_unknown_command_is_unsupported_and_counted(t: Table) -> None:
    t.host.receive(long(mavlink.MAV_CMD_NAV_TAKEOFF))
    (ack,) = t.host.take()
    assert (ack.command, ack.result) == (mavlink.MAV_CMD_NAV_TAKEOFF, UNSUPPORTED)
    assert t.host.dropped == {"unsupported:COMMAND_LONG": 1}


def test_an_invalid_field_is_denied_and_counted_under_its_wire_name(t: Table) -> None:
    t.host.receive(long(PING, 2.5))
    t.host.receive(mavlink.MAVLink_command_int_message(SYSID, 0, 0, PING, 0, 0, float("nan"), 0, 0, 0, 0, 0, 0))
    assert [a.result for a in t.host.take()] == [DENIED, DENIED]
    assert t.host.dropped == {"invalid:COMMAND_LONG:param1": 1, "invalid:COMMAND_INT:param1": 1}
    assert [f.get("invalid") for name, f in t.host.events] == ["param1", "param1"]


def test_what_a_request_sends_follows_its_ack(t: Table) -> None:
    t.host.receive(long(PING, 7))
    ack, text = t.host.take()
    assert (ack.get_type(), ack.result) == ("COMMAND_ACK", ACCEPTED)
    assert (text.get_type(), text.text) == ("STATUSTEXT", "asked 7")


def test_a_duplicated_frame_is_answered_again_and_not_executed_again(t: Table) -> None:
    frame = t.host.frame(long(GOTO, 0, 0, 0, 0, 10.0, 5.0))
    t.host.receive(frame)
    t.apad.set_primitive(prim.hold(t.apad.primitive, 0.0, 0.0))  # even if the vehicle has moved on since
    t.host.receive(frame)
    assert len(t.executed) == 1
    assert [(a.command, a.result) for a in t.host.take()] == [(GOTO, ACCEPTED)] * 2
    assert t.host.event_names() == ["command", "command_duplicate"]


def test_a_resent_command_is_not_run_twice_while_its_effect_holds_and_is_run_again_after(t: Table) -> None:
    t.host.receive(long(GOTO, 0, 0, 0, 0, 10.0, 5.0))
    t.host.receive(long(GOTO, 0, 0, 0, 0, 10.0, 5.0))  # a new frame: the GCS re-sent after a lost ACK
    assert len(t.executed) == 1
    assert t.host.event_names() == ["command", "command_retry"]
    t.apad.set_primitive(prim.hold(t.apad.primitive, 0.0, 0.0))  # e.g. the failsafe: the Go To is over
    t.host.receive(long(GOTO, 0, 0, 0, 0, 10.0, 5.0))
    assert len(t.executed) == 2
    assert t.apad.primitive.target_x_m == 10.0
    assert [a.result for a in t.host.take()] == [ACCEPTED] * 3


def test_a_command_has_one_handler(t: Table) -> None:
    with pytest.raises(ValueError, match="MAV_CMD_DO_REPOSITION"):
        t.table.register(GOTO, lambda cmd: ACCEPT)
