"""Hostile values in well-formed MAVLink: real frames with a valid CRC, encoded by a Codec and sent
over the in-memory transport to the SITL aPad, to every command and message it handles.

For each: `poll()` does not raise, a command is answered DENIED (or UNSUPPORTED), nothing about the
vehicle changes, and `vehicle.dropped` grows by exactly one count under the expected reason.
"""

from __future__ import annotations

import json
import math
from collections import Counter
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from apad_sitl import param_server
from apad_sitl.endpoint import SitlVehicle
from apad_sitl.params import PARAMS, ApadParams
from apad_sitl.primitives import Refusal
from apad_sitl.vocabulary import Latch, RoverMode
from mavlink_dialect import MAV_CMD_APAD_DOCK, MAV_CMD_APAD_UNDOCK, Codec, mavlink, memory_pair
from missiontime import VirtualClock
from mussel_sim.geo import LocalFrame
from mussel_sim.vocabulary import MusselState

HOME = (43.94, 15.44)
FRAME = LocalFrame(*HOME)
SYSID = 1
NAN, INF = math.nan, math.inf
HUGE = 3.0e38  # near float32's largest
DENIED = mavlink.MAV_RESULT_DENIED
ACCEPTED = mavlink.MAV_RESULT_ACCEPTED
Msg = Any


def latlon_e7(x_m: float, y_m: float) -> tuple[int, int]:
    lat, lon = FRAME.to_geodetic(x_m, y_m)
    return round(float(lat) * 1e7), round(float(lon) * 1e7)


class Bench:
    """A vehicle attached to a scheduler whose clock never moves, and a bare GCS on the other end.

    Set up busy (two aMussels heard, one docking into slot 1) so a wrongly accepted command shows.
    """

    HANDLED: tuple[int, ...] = ()  # message ids the vehicle handles (filled in below)
    COMMANDS: tuple[int, ...] = ()  # MAV_CMDs it handles, and one it does not

    def __init__(self, log_dir: Path | None = None) -> None:
        self.clock = VirtualClock()
        vehicle_end, self.gcs_end = memory_pair()
        self.vehicle = SitlVehicle(vehicle_end, ApadParams(), *HOME, system_id=SYSID, log_dir=log_dir)
        self.vehicle.attach(self.clock.scheduler)
        self.codec = Codec(250, 190)
        self.send(mavlink.MAVLink_amussel_status_message(0, 24, *latlon_e7(0.5, 0.0), 0.0, 0.8, 4080, 2, 1))
        self.send(mavlink.MAVLink_amussel_status_message(0, 31, *latlon_e7(-0.5, 0.0), 0.0, 0.8, 4080, 2, 1))
        self.send(mavlink.MAVLink_command_long_message(SYSID, 1, MAV_CMD_APAD_DOCK, 0, 1, 31, 0, 0, 0, 0, 0))
        assert self.answers()[-1].result == ACCEPTED
        assert self.vehicle.primitive.slot_state(1).latch == Latch.CLOSING
        assert not self.vehicle.dropped

    def send(self, msg: Msg) -> None:
        """Encode `msg` into a real frame and let the vehicle read it, as its poller would."""
        self.send_raw(self.codec.encode(msg))

    def send_raw(self, frame: bytes) -> None:
        self.gcs_end.send(frame)
        self.vehicle.poll()

    def answers(self) -> list[Msg]:
        return [m for data in self.gcs_end.receive() for m in self.codec.decode(data)]

    def snapshot(self) -> tuple[Any, ...]:
        v = self.vehicle
        tasks = {mid: (t.period_us, t.next_us, t.active) for mid, t in v.streams._tasks.items()}
        return (v.state, v.primitive, v.mode, v.armed, v.speed_override_mps, v.params,
                {i: v.mussels[i] for i in v.mussels}, tasks, v.failsafe_active, v.last_gcs_heartbeat_us)


def _learn_what_the_vehicle_handles() -> None:
    with SitlVehicle(memory_pair()[0], ApadParams(), *HOME) as v:
        Bench.HANDLED = tuple(sorted(v._handlers))
        Bench.COMMANDS = (*sorted(v.commands._entries), mavlink.MAV_CMD_NAV_TAKEOFF)


_learn_what_the_vehicle_handles()


@pytest.fixture
def bench() -> Iterator[Bench]:
    b = Bench()
    yield b
    b.vehicle.close()


def command_long(command: int, *params: float, target: int = SYSID) -> Msg:
    p = [*params, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0][:7]
    return mavlink.MAVLink_command_long_message(target, 1, command, 0, *p)


def command_int(command: int, frame: int, params: tuple[float, float, float, float], x: int, y: int) -> Msg:
    return mavlink.MAVLink_command_int_message(SYSID, 1, frame, command, 0, 0, *params, x, y, 0.0)


def refused(bench: Bench, msg: Msg, reason: str) -> list[Msg]:
    """Send `msg`; assert nothing changed and exactly `reason` was counted. Returns what came back."""
    before, dropped = bench.snapshot(), Counter(bench.vehicle.dropped)
    bench.send(msg)
    assert bench.snapshot() == before
    assert bench.vehicle.dropped - dropped == Counter({reason: 1})
    return bench.answers()


def the_ack(answers: list[Msg], command: int) -> Msg:
    [ack] = [m for m in answers if m.get_type() == "COMMAND_ACK"]
    assert ack.command == command and (ack.target_system, ack.target_component) == (250, 190)
    return ack


# ---------------------------------------------------------------------------- commands

LAT, LON = (v / 1e7 for v in latlon_e7(10.0, 10.0))
GLOBAL_INT = mavlink.MAV_FRAME_GLOBAL_INT
REPO = mavlink.MAV_CMD_DO_REPOSITION
LONG_CASES: list[tuple[str, int, tuple[float, ...], str]] = [
    # (case, command, param1.., field counted)
    *[(f"set_mode base {p}", mavlink.MAV_CMD_DO_SET_MODE, (p, RoverMode.GUIDED), "param1")
      for p in (NAN, INF, -INF, -1.0, 256.0, 1.5, HUGE)],
    *[(f"set_mode custom {p}", mavlink.MAV_CMD_DO_SET_MODE, (1.0, p), "param2")
      for p in (NAN, INF, -INF, -1.0, 15.5, HUGE, 0.0, 7.0)],  # 0 MANUAL and 7: no modes of an aPad
    *[(f"arm {p}", mavlink.MAV_CMD_COMPONENT_ARM_DISARM, (p,), "param1") for p in (NAN, INF, -INF, 2.0, -1.0, 0.5)],
    *[(f"speed {p}", mavlink.MAV_CMD_DO_CHANGE_SPEED, (1.0, p), "param2")
      for p in (NAN, INF, -INF, 0.0, -3.0, -HUGE)],
    *[(f"reposition lat {p}", REPO, (-1.0, 1.0, 0.0, NAN, p, LON), "param5") for p in (NAN, INF, -INF, 90.5, -HUGE)],
    *[(f"reposition lon {p}", REPO, (-1.0, 1.0, 0.0, NAN, LAT, p), "param6") for p in (NAN, INF, -INF, 180.5, HUGE)],
    ("reposition speed inf", REPO, (INF, 1.0, 0.0, NAN, LAT, LON), "param1"),
    ("reposition radius inf", REPO, (-1.0, 1.0, INF, NAN, LAT, LON), "param3"),
    *[(f"request {p}", mavlink.MAV_CMD_REQUEST_MESSAGE, (p,), "param1") for p in (NAN, INF, -INF, -1.0, 1.5, 2.0**24)],
    *[(f"request slot {p}", mavlink.MAV_CMD_REQUEST_MESSAGE, (mavlink.MAVLINK_MSG_ID_DOCK_SLOT_STATUS, p), "param2")
      for p in (NAN, INF, -1.0, 5.0, 1.5)],
    *[(f"interval id {p}", mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, (p, 100_000), "param1") for p in (NAN, INF, -5.0)],
    *[(f"interval {p}", mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, (mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, p), "param2")
      for p in (NAN, INF, -INF, -2.0, -0.5, 0.5, HUGE)],
]
SLOT_CASES: list[tuple[str, int, tuple[float, float], str, Refusal]] = [
    *[(f"dock slot {p}", MAV_CMD_APAD_DOCK, (p, 24), "param1", Refusal.BAD_SLOT)
      for p in (NAN, INF, -INF, 0.0, 5.0, 1.5, -1.0, HUGE)],
    *[(f"dock id {p}", MAV_CMD_APAD_DOCK, (2, p), "param2", Refusal.BAD_MUSSEL_ID)
      for p in (NAN, INF, -INF, 0.0, 65536.0, -1.0, 24.5, HUGE)],
    *[(f"undock slot {p}", MAV_CMD_APAD_UNDOCK, (p, 0), "param1", Refusal.BAD_SLOT)
      for p in (NAN, INF, 0.0, 5.0, 1.5, -HUGE)],
    *[(f"undock id {p}", MAV_CMD_APAD_UNDOCK, (1, p), "param2", Refusal.BAD_MUSSEL_ID)
      for p in (NAN, -INF, 65536.0, -1.0, 31.5)],
]


@pytest.mark.parametrize(("command", "params", "field"), [c[1:] for c in LONG_CASES], ids=[c[0] for c in LONG_CASES])
def test_a_command_long_with_a_bad_parameter_is_denied_counted_and_changes_nothing(
    bench: Bench, command: int, params: tuple[float, ...], field: str
) -> None:
    answers = refused(bench, command_long(command, *params), f"invalid:COMMAND_LONG:{field}")
    assert the_ack(answers, command).result == DENIED
    assert [m.get_type() for m in answers] == ["COMMAND_ACK"]  # and nothing requested is sent


@pytest.mark.parametrize(("command", "params", "field", "refusal"), [c[1:] for c in SLOT_CASES],
                         ids=[c[0] for c in SLOT_CASES])
def test_a_dock_or_undock_with_no_slot_or_no_mussel_id_is_refused_with_its_reason(
    bench: Bench, command: int, params: tuple[float, float], field: str, refusal: Refusal
) -> None:
    answers = refused(bench, command_long(command, *params), f"invalid:COMMAND_LONG:{field}")
    ack = the_ack(answers, command)
    assert (ack.result, ack.result_param2) == (DENIED, refusal)
    [text] = [m.text for m in answers if m.get_type() == "STATUSTEXT"]
    assert text.endswith(("slot must be 1..4", "bad aMussel id"))


INT_CASES: list[tuple[str, int, int, int, str]] = [
    ("frame unknown", 99, *latlon_e7(10.0, 10.0), "frame"),
    ("frame local", mavlink.MAV_FRAME_LOCAL_NED, *latlon_e7(10.0, 10.0), "frame"),
    ("lat int32 max", GLOBAL_INT, 2**31 - 1, latlon_e7(10.0, 10.0)[1], "x"),
    ("lat int32 min", GLOBAL_INT, -(2**31), latlon_e7(10.0, 10.0)[1], "x"),
    ("lat 90.0000001", GLOBAL_INT, 900_000_001, latlon_e7(10.0, 10.0)[1], "x"),
    ("lon int32 max", GLOBAL_INT, latlon_e7(10.0, 10.0)[0], 2**31 - 1, "y"),
    ("lon int32 min", GLOBAL_INT, latlon_e7(10.0, 10.0)[0], -(2**31), "y"),
]


@pytest.mark.parametrize(("frame", "x", "y", "field"), [c[1:] for c in INT_CASES], ids=[c[0] for c in INT_CASES])
def test_a_command_int_reposition_with_no_position_is_denied_and_counted(
    bench: Bench, frame: int, x: int, y: int, field: str
) -> None:
    answers = refused(bench, command_int(REPO, frame, (-1.0, 1.0, 0.0, NAN), x, y), f"invalid:COMMAND_INT:{field}")
    assert the_ack(answers, REPO).result == DENIED


@pytest.mark.parametrize("speed", [INF, -INF])
def test_a_command_int_reposition_with_an_infinite_speed_is_denied(bench: Bench, speed: float) -> None:
    answers = refused(bench, command_int(REPO, GLOBAL_INT, (speed, 1.0, 0.0, NAN), *latlon_e7(10.0, 10.0)),
                      "invalid:COMMAND_INT:param1")
    assert the_ack(answers, REPO).result == DENIED


@pytest.mark.parametrize("command", [mavlink.MAV_CMD_NAV_TAKEOFF, 0, 31000, 65535])
def test_an_unknown_command_is_unsupported_and_counted(bench: Bench, command: int) -> None:
    answers = refused(bench, command_long(command, NAN, INF, -INF, HUGE), "unsupported:COMMAND_LONG")
    assert the_ack(answers, command).result == mavlink.MAV_RESULT_UNSUPPORTED


@pytest.mark.parametrize("command", [mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, mavlink.MAV_CMD_GET_HOME_POSITION])
def test_commands_without_parameters_ignore_whatever_is_in_them(bench: Bench, command: int) -> None:
    before = bench.snapshot()
    bench.send(command_long(command, NAN, INF, -INF, HUGE, NAN, NAN, NAN))
    answers = bench.answers()
    assert the_ack(answers, command).result == ACCEPTED
    assert len(answers) == 2 and bench.snapshot() == before and not bench.vehicle.dropped


def test_do_set_mode_with_an_infinite_mode_no_longer_kills_the_vehicle(bench: Bench) -> None:
    """The bug that started this: int(+inf) raised OverflowError out of poll() and ended `vil sitl`."""
    bench.send(command_long(mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, INF))
    bench.send(command_long(mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, RoverMode.GUIDED))
    acks = [m for m in bench.answers() if m.get_type() == "COMMAND_ACK"]
    assert [a.result for a in acks] == [DENIED, ACCEPTED]
    assert bench.vehicle.mode == RoverMode.GUIDED


def test_commands_for_another_system_are_not_ours_to_count(bench: Bench) -> None:
    before = bench.snapshot()
    bench.send(command_long(mavlink.MAV_CMD_DO_SET_MODE, NAN, INF, target=7))
    assert bench.answers() == [] and bench.snapshot() == before and not bench.vehicle.dropped


# ---------------------------------------------------------------------------- messages


@pytest.mark.parametrize("custom_mode", [0, 7, 2**32 - 1])
def test_legacy_set_mode_to_no_mode_of_the_apad_is_denied_and_counted(bench: Bench, custom_mode: int) -> None:
    msg = mavlink.MAVLink_set_mode_message(SYSID, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, custom_mode)
    answers = refused(bench, msg, "invalid:SET_MODE:custom_mode")
    assert the_ack(answers, mavlink.MAVLINK_MSG_ID_SET_MODE).result == DENIED


@pytest.mark.parametrize(("name", "value", "field"), [
    (b"SPEED_MAX", NAN, "param_value"),
    (b"SPEED_MAX", INF, "param_value"),
    (b"SPEED_MAX", -INF, "param_value"),
    (b"SPEED_MAX", HUGE, "param_value"),
    (b"SPEED_MAX", -1.0, "param_value"),
    (b"FS_GCS_ENABLE", 0.5, "param_value"),  # an integer parameter
    (b"SYSID_THISMAV", 256.0, "param_value"),
    (b"NOPE", 1.0, "param_id"),
    (b"\xff\xfe\x80SPEED", 1.0, "param_id"),
    (b"", 1.0, "param_id"),
])
def test_param_set_out_of_its_bounds_is_refused_counted_and_answered_with_the_old_value(
    bench: Bench, name: bytes, value: float, field: str
) -> None:
    msg = mavlink.MAVLink_param_set_message(SYSID, 1, name, value, mavlink.MAV_PARAM_TYPE_REAL32)
    answers = refused(bench, msg, f"invalid:PARAM_SET:{field}")
    assert "STATUSTEXT" in [m.get_type() for m in answers]
    values = [m for m in answers if m.get_type() == "PARAM_VALUE"]
    if field == "param_value":
        [pv] = values
        assert pv.param_id == name.decode() and pv.param_value == float(getattr(ApadParams(), _field(name)))
    else:
        assert values == []


def _field(name: bytes) -> str:
    from apad_sitl.params import BY_NAME

    return BY_NAME[name.decode()].field


@pytest.mark.parametrize(("name", "index", "field"), [
    (b"", 32767, "param_index"),
    (b"SPEED_MAX", len(PARAMS), "param_index"),  # one past the last: the index wins over the name (MAVLink's rule)
    (b"NOPE", -1, "param_id"),
    (b"\xff", -32768, "param_id"),
])
def test_param_read_of_no_parameter_is_counted_and_unanswered(
    bench: Bench, name: bytes, index: int, field: str
) -> None:
    answers = refused(bench, mavlink.MAVLink_param_request_read_message(SYSID, 1, name, index),
                      f"invalid:PARAM_REQUEST_READ:{field}")
    assert answers == []


@pytest.mark.parametrize("mission_type", [3, 77, 254])
def test_mission_list_of_an_unknown_mission_type_is_counted_and_unanswered(bench: Bench, mission_type: int) -> None:
    answers = refused(bench, mavlink.MAVLink_mission_request_list_message(SYSID, 1, mission_type),
                      "invalid:MISSION_REQUEST_LIST:mission_type")
    assert answers == []


@pytest.mark.parametrize(("mussel_id", "lat", "lon", "state", "field"), [
    (0, 0, 0, MusselState.FLOATING, "mussel_id"),
    (24, 2**31 - 1, 0, MusselState.FLOATING, "lat"),
    (24, -(2**31), 0, MusselState.FLOATING, "lat"),
    (24, 900_000_001, 0, MusselState.FLOATING, "lat"),
    (24, 0, 1_800_000_001, MusselState.FLOATING, "lon"),
    (24, 0, -(2**31), MusselState.FLOATING, "lon"),
    (24, *latlon_e7(0.5, 0.0), 6, "state"),
    (24, *latlon_e7(0.5, 0.0), 255, "state"),
    (31, *latlon_e7(30.0, 0.0), 99, "state"),  # would have pulled the docking aMussel out of reach
])
def test_an_amussel_status_with_no_position_or_state_is_dropped_and_counted(
    bench: Bench, mussel_id: int, lat: int, lon: int, state: int, field: str
) -> None:
    msg = mavlink.MAVLink_amussel_status_message(0, mussel_id, lat, lon, NAN, INF, 4080, state, 1)
    assert refused(bench, msg, f"invalid:AMUSSEL_STATUS:{field}") == []


def test_a_gcs_heartbeat_and_an_ftp_request_full_of_ones_do_not_upset_it(bench: Bench) -> None:
    bench.send(mavlink.MAVLink_heartbeat_message(255, 255, 255, 2**32 - 1, 255, 255))
    bench.send(mavlink.MAVLink_file_transfer_protocol_message(255, SYSID, 1, [255] * 251))
    [reply] = bench.answers()
    assert reply.get_type() == "FILE_TRANSFER_PROTOCOL" and reply.payload[3] == 129  # NAK
    assert not bench.vehicle.dropped


# ---------------------------------------------------------------------------- the dispatch boundary


def test_an_exception_in_a_handler_is_caught_counted_logged_and_the_next_message_is_handled(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    bench = Bench(tmp_path)

    def broken(*args: object) -> None:
        raise RuntimeError("a bug")

    monkeypatch.setattr(param_server, "with_param", broken)
    try:
        bench.send(mavlink.MAVLink_param_set_message(SYSID, 1, b"SPEED_MAX", 1.0, mavlink.MAV_PARAM_TYPE_REAL32))
        flag = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
        bench.send(command_long(mavlink.MAV_CMD_DO_SET_MODE, flag, RoverMode.GUIDED))
        assert bench.vehicle.dropped == Counter({"handler_error:PARAM_SET": 1})
        assert [m.get_type() for m in bench.answers()] == ["HEARTBEAT", "COMMAND_ACK"]  # the mode change
        assert bench.vehicle.mode == RoverMode.GUIDED
    finally:
        bench.vehicle.close()
    events = [json.loads(line) for line in (tmp_path / "apad1.events.jsonl").read_text().splitlines()]
    [error] = [e for e in events if e["event"] == "handler_error"]
    assert error["message"] == "PARAM_SET" and "a bug" in error["error"]


FLOATS = (NAN, INF, -INF, HUGE, -HUGE, -1.0, 0.5, 1.0)


def test_every_command_survives_every_hostile_number_in_every_parameter() -> None:
    """Each registered MAV_CMD, each parameter in turn set to each hostile float (COMMAND_LONG) and
    x, y to the int32 extremes (COMMAND_INT): one ACK each, never a handler error."""
    bench = Bench()
    commands = sorted(bench.vehicle.commands._entries)
    assert len(commands) == 10
    sent = 0
    for command in commands:
        for i in range(7):
            for value in FLOATS:
                params = [1.0] * 7
                params[i] = value
                bench.send(command_long(command, *params))
                sent += 1
        for x, y in ((2**31 - 1, 0), (-(2**31), 0), (0, 2**31 - 1), (0, -(2**31)), (0, 0)):
            for frame in (GLOBAL_INT, 255):
                bench.send(command_int(command, frame, (NAN, INF, -INF, HUGE), x, y))
                sent += 1
    acks = [m for m in bench.answers() if m.get_type() == "COMMAND_ACK"]
    assert len(acks) == sent
    assert not [k for k in bench.vehicle.dropped if k.startswith("handler_error")]
    bench.vehicle.close()


def test_every_message_handler_survives_every_extreme_in_every_field() -> None:
    """Each message the vehicle handles, every field in turn set to each extreme its type can carry."""
    bench = Bench()
    handled = [mavlink.mavlink_map[i] for i in sorted(bench.vehicle._handlers)]
    assert len(handled) == 10
    sent = 0
    for cls in handled:
        for field, ftype in zip(cls.fieldnames, cls.fieldtypes, strict=True):
            for value in _extremes(ftype):
                bench.send(cls(*_args(cls, field, value)))
                sent += 1
        bench.answers()
    assert sent > 200
    assert not [k for k in bench.vehicle.dropped if k.startswith("handler_error")]
    bench.vehicle.close()


def _extremes(ftype: str) -> tuple[Any, ...]:
    if ftype in ("float", "double"):
        return FLOATS
    if ftype == "char":
        return (b"\xff" * 16, b"SPEED_MAX", b"")
    bits = int(ftype.removeprefix("u").removeprefix("int").removesuffix("_t"))
    lo, hi = (0, 2**bits - 1) if ftype.startswith("u") else (-(2 ** (bits - 1)), 2 ** (bits - 1) - 1)
    return (lo, hi, 0, 1, 255 if hi >= 255 else hi)


def _args(cls: Any, field: str, value: Any) -> list[Any]:
    """Constructor arguments for `cls`: addressed to us, a Dock where a command goes, `value` in `field`."""
    lengths = dict(zip(cls.ordered_fieldnames, cls.array_lengths, strict=True))
    args = []
    for name, ftype in zip(cls.fieldnames, cls.fieldtypes, strict=True):
        if name == field:
            v = value
        elif name == "target_system":
            v = SYSID
        elif name == "command":
            v = MAV_CMD_APAD_DOCK
        elif ftype == "char":
            v = b"SPEED_MAX"
        else:
            v = 1.0 if ftype in ("float", "double") else 1
        if lengths[name] and ftype != "char":
            v = [v] * lengths[name]
        args.append(v)
    return args


def _field_values(ftype: str, length: int) -> st.SearchStrategy[Any]:
    if ftype == "char":
        return st.binary(max_size=length)
    if ftype in ("float", "double"):
        one: st.SearchStrategy[Any] = st.floats(width=32 if ftype == "float" else 64)
    else:
        bits = int(ftype.removeprefix("u").removeprefix("int").removesuffix("_t"))
        lo, hi = (0, 2**bits - 1) if ftype.startswith("u") else (-(2 ** (bits - 1)), 2 ** (bits - 1) - 1)
        one = st.integers(lo, hi)
    return st.lists(one, min_size=length, max_size=length) if length else one


@st.composite
def _handled_message(draw: st.DrawFn) -> Any:
    msg_ids = sorted(Bench.HANDLED)
    cls = mavlink.mavlink_map[draw(st.sampled_from(msg_ids))]
    lengths = dict(zip(cls.ordered_fieldnames, cls.array_lengths, strict=True))
    args = []
    for name, ftype in zip(cls.fieldnames, cls.fieldtypes, strict=True):
        if name in ("target_system", "target_component"):  # for us: 0 (broadcast) or our ids
            args.append(draw(st.sampled_from([0, 1])))
        elif name == "command":
            args.append(draw(st.sampled_from(Bench.COMMANDS)))
        else:
            args.append(draw(_field_values(ftype, lengths[name])))
    return cls(*args)


@pytest.fixture(scope="module")
def fuzz_bench() -> Iterator[Bench]:
    b = Bench()
    yield b
    b.vehicle.close()


@settings(max_examples=300, deadline=None, derandomize=True, database=None, suppress_health_check=list(HealthCheck))
@given(st.lists(_handled_message(), min_size=1, max_size=5))
def test_random_well_formed_messages_never_reach_a_handler_error(fuzz_bench: Bench, messages: list[Any]) -> None:
    bench = fuzz_bench
    for msg in messages:
        bench.send(msg)
    bench.answers()
    assert not [k for k in bench.vehicle.dropped if k.startswith("handler_error")]
