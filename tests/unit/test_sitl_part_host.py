"""The narrow host the SITL aPad's parts are built with, and the state that reports its changes.

`RecordingHost` is a small real `apad_sitl.host.PartHost`: real MAVLink frames in (encoded by a GCS's
codec, decoded by the aPad's), and what a part sends, logs and counts recorded as it went out
(every sent message goes through the aPad's codec and back, so a test reads what the wire carries).
`Registry` is a small real `CommandRegistry`. The other test_sitl_part_*.py files build each part
alone with these.
"""

from __future__ import annotations

import subprocess
import sys
from collections import Counter
from dataclasses import replace
from typing import Any

import pytest

from apad_sitl import primitives as prim
from apad_sitl.host import Command, CommandHandler, MessageHandler, Reply, invalid_reason, unsupported_reason
from apad_sitl.params import ApadParams
from apad_sitl.state import ApadState
from apad_sitl.vocabulary import RoverMode
from mavlink_dialect import Codec, mavlink

GCS = (250, 190)  # the GCS's system and component
SYSID, COMPID = 1, mavlink.MAV_COMP_ID_AUTOPILOT1


class RecordingHost:
    """A `PartHost` that records what the part does with it."""

    def __init__(self, system_id: int = SYSID, component_id: int = COMPID) -> None:
        self.now_us = 0
        self.closed = False
        self.system_id, self.component_id = system_id, component_id
        self.handlers: dict[int, MessageHandler] = {}
        self.sent: list[Any] = []  # decoded from the frames the part sent
        self.events: list[tuple[str, dict[str, Any]]] = []
        self.dropped: Counter[str] = Counter()
        self._aircraft = Codec(system_id, component_id)  # ours: encodes what is sent, decodes what comes
        self._gcs = Codec(*GCS)
        self._wire = Codec(*GCS)  # reads back what we sent

    # ------------------------------------------------------------ PartHost

    def on(self, msg_id: int, handler: MessageHandler) -> None:
        if msg_id in self.handlers:
            raise ValueError(f"message id {msg_id} already has a handler")
        self.handlers[msg_id] = handler

    def send(self, msg: Any) -> None:
        (decoded,) = self._wire.decode(self._aircraft.encode(msg))
        self.sent.append(decoded)

    def for_us(self, target_system: int, target_component: int) -> bool:
        return target_system in (0, self.system_id) and target_component in (0, self.component_id)

    def count_invalid(self, message: str, field: str) -> None:
        self.dropped[invalid_reason(message, field)] += 1

    def count_unsupported(self, message: str) -> None:
        self.dropped[unsupported_reason(message)] += 1

    def event(self, event: str, /, **fields: Any) -> None:
        self.events.append((event, fields))

    def statustext(self, severity: int, text: str) -> None:
        self.send(mavlink.MAVLink_statustext_message(severity, text.encode("utf-8")[:50]))

    # ------------------------------------------------------------ for the tests

    def frame(self, msg: Any) -> bytes:
        """`msg` as the GCS sends it: a real frame, with the GCS's next sequence number."""
        return self._gcs.encode(msg)

    def receive(self, msg_or_frame: Any) -> None:
        """Decode a frame (or encode `msg` first) and hand each message to the handler registered for it."""
        data = msg_or_frame if isinstance(msg_or_frame, bytes) else self.frame(msg_or_frame)
        for msg in self._aircraft.decode(data):
            handler = self.handlers.get(msg.get_msgId())
            if handler is not None:
                handler(msg)

    def take(self) -> list[Any]:
        """What was sent since the last take."""
        sent, self.sent = self.sent, []
        return sent

    def types(self) -> list[str]:
        return [m.get_type() for m in self.take()]

    def event_names(self) -> list[str]:
        return [name for name, _ in self.events]


class Registry:
    """A `CommandRegistry` that keeps the handlers, so a test calls them with a `Command` of its own."""

    def __init__(self) -> None:
        self.handlers: dict[int, tuple[CommandHandler, bool]] = {}

    def register(self, command: int, handler: CommandHandler, *, stateful: bool = False) -> None:
        if command in self.handlers:
            raise ValueError(f"{command} already has a handler")
        self.handlers[command] = (handler, stateful)

    def run(self, command: int, *params: float, frame: int | None = None) -> Reply:
        """Call the handler of `command` with param1.. (the rest 0), and the answer's `then` if accepted."""
        p = (*params, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)[:7]
        reply = self.handlers[command][0](Command(command, p, frame, *GCS))
        if reply.result == mavlink.MAV_RESULT_ACCEPTED and reply.then is not None:
            reply.then()
        return reply


# ---------------------------------------------------------------- the host itself


def test_the_host_delivers_real_frames_and_reads_back_what_was_sent() -> None:
    host = RecordingHost()
    got: list[Any] = []
    host.on(mavlink.MAVLINK_MSG_ID_PING, got.append)
    host.receive(mavlink.MAVLink_ping_message(5, 7, SYSID, COMPID))
    assert [(m.seq, m.get_srcSystem(), m.get_srcComponent()) for m in got] == [(7, *GCS)]
    with pytest.raises(ValueError):
        host.on(mavlink.MAVLINK_MSG_ID_PING, got.append)
    host.statustext(mavlink.MAV_SEVERITY_WARNING, "x" * 60)
    (text,) = host.take()
    assert (text.get_type(), text.get_srcSystem(), text.text) == ("STATUSTEXT", SYSID, "x" * 50)


PARTS = ("command_handler", "streams", "modes", "navigation", "docking", "param_server", "mission_protocol")


@pytest.mark.parametrize("part", PARTS)
def test_a_part_loads_without_the_vehicle_and_without_the_other_parts(part: str) -> None:
    code = (f"import sys; import apad_sitl.{part}; "
            "print(' '.join(sorted(m for m in sys.modules if m.startswith('apad_sitl.'))))")
    loaded = set(subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True)
                 .stdout.split())
    assert f"apad_sitl.{part}" in loaded
    assert "apad_sitl.endpoint" not in loaded
    assert not loaded & {f"apad_sitl.{p}" for p in PARTS if p != part}


# ---------------------------------------------------------------- the state that reports its changes


def test_the_state_reports_primitive_mode_and_arming_changes_to_its_listeners_in_order() -> None:
    apad = ApadState(ApadParams())
    heard: list[tuple[Any, ...]] = []
    apad.on_primitive(lambda old, new: heard.append(("first", old.kind.name, new.kind.name)))
    apad.on_primitive(lambda old, new: heard.append(("second", old.kind.name, new.kind.name)))
    apad.on_mode(lambda mode: heard.append(("mode", mode)))
    apad.on_armed(lambda armed: heard.append(("armed", armed)))

    apad.set_primitive(prim.go_to(apad.primitive, 10.0, 0.0))
    apad.set_primitive(apad.primitive)  # the very same state: nothing to report
    apad.set_mode(RoverMode.GUIDED)
    apad.set_mode(RoverMode.GUIDED)  # no change
    apad.set_armed(False)
    apad.set_armed(False)
    assert heard == [("first", "IDLE", "GOTO"), ("second", "IDLE", "GOTO"), ("mode", RoverMode.GUIDED),
                     ("armed", False)]
    assert (apad.mode, apad.armed, apad.primitive.target_x_m) == (RoverMode.GUIDED, False, 10.0)

    # An equal but new primitive state is a change.
    heard.clear()
    apad.set_primitive(replace(apad.primitive))
    assert heard == [("first", "GOTO", "GOTO"), ("second", "GOTO", "GOTO")]
