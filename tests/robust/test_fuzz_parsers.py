"""Fuzz the MAVLink entry points of the GCS (Link's transport poller -> Codec.decode) and the SITL
(SitlVehicle.poll) with garbage, truncated, bit-flipped and unknown-id frames: nothing may raise.

CI runs a few hundred inputs per target; by hand, e.g.

    VIL_FUZZ_EXAMPLES=200000 .venv/bin/pytest -q -s tests/robust/test_fuzz_parsers.py

prints how many inputs each target took.
"""

from __future__ import annotations

import math
import os
import struct

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pymavlink.generator.mavcrc import x25crc
from robust_helpers import HOME, SYSID, latlon_e7

from apad_sitl.endpoint import SitlVehicle
from apad_sitl.params import ApadParams
from apad_sitl.vocabulary import Latch, Primitive, Progress
from gcs.link.router import Link
from mavlink_dialect import MAV_CMD_APAD_DOCK, Codec, mavlink, memory_pair
from missiontime import VirtualClock
from mussel_sim.vocabulary import MusselState

EXAMPLES = int(os.environ.get("VIL_FUZZ_EXAMPLES", "300"))
FUZZ = settings(max_examples=EXAMPLES, deadline=None, derandomize=True, database=None,
                suppress_health_check=list(HealthCheck))
TRIED: dict[str, int] = {"gcs": 0, "sitl": 0}

_sender = Codec(1, 1)
VALID_FRAMES = [
    _sender.encode(m) for m in (
        mavlink.MAVLink_heartbeat_message(11, 3, 0, 4, 4, 3),
        mavlink.MAVLink_command_long_message(SYSID, 1, MAV_CMD_APAD_DOCK, 0, 1, 24, 0, 0, 0, 0, 0),
        mavlink.MAVLink_command_int_message(SYSID, 1, 6, mavlink.MAV_CMD_DO_REPOSITION, 0, 0, -1, 1, 0, 0,
                                            *latlon_e7(5.0, 5.0), 0.0),
        mavlink.MAVLink_amussel_status_message(0, 24, *latlon_e7(0.5, 0), 0.0, 0.8, 4080, 2, 1),
        mavlink.MAVLink_param_set_message(SYSID, 1, b"SPEED_MAX", 1.0, 9),
        mavlink.MAVLink_dock_slot_status_message(0, 1, 24, 2, 1),
        mavlink.MAVLink_global_position_int_message(0, *latlon_e7(1, 1), 0, 0, 0, 0, 0, 0),
    )
]


def _unknown_id_frame(msg_id: int, payload: bytes) -> bytes:
    """A well-formed MAVLink 2 frame of a message id the dialect does not know (CRC extra 0)."""
    header = struct.pack("<BBBBBBBHB", 0xFD, len(payload), 0, 0, 7, 1, 1, msg_id & 0xFFFF, msg_id >> 16)
    crc = x25crc(header[1:] + payload)
    crc.accumulate(bytes([0]))
    return header + payload + struct.pack("<H", crc.crc)


def _mutate(data: st.DataObject) -> bytes:
    frame = bytearray(data.draw(st.sampled_from(VALID_FRAMES)))
    kind = data.draw(st.sampled_from(["flip", "truncate", "splice", "length", "garbage", "unknown"]))
    if kind == "flip":
        for i in data.draw(st.lists(st.integers(0, len(frame) - 1), min_size=1, max_size=4)):
            frame[i] ^= 1 << data.draw(st.integers(0, 7))
    elif kind == "truncate":
        frame = frame[: data.draw(st.integers(0, len(frame) - 1))]
    elif kind == "splice":
        frame = frame + data.draw(st.binary(max_size=40)) + bytearray(data.draw(st.sampled_from(VALID_FRAMES)))
    elif kind == "length":
        frame[1] = data.draw(st.integers(0, 255))
    elif kind == "garbage":
        frame = bytearray(data.draw(st.binary(max_size=300)))
    else:
        msg_id = data.draw(st.integers(60000, 2**24 - 1))
        frame = bytearray(_unknown_id_frame(msg_id, data.draw(st.binary(max_size=60))))
    return bytes(frame)


@pytest.fixture(scope="module", autouse=True)
def report() -> object:
    yield
    print(f"\nfuzz inputs tried: GCS link {TRIED['gcs']}, SITL aPad {TRIED['sitl']}; crashes: 0")


@FUZZ
@given(st.data())
def test_gcs_link_survives_any_bytes(data: st.DataObject) -> None:
    clock = VirtualClock()
    gcs_end, far_end = memory_pair()
    link = Link(clock)
    link.add_transport(gcs_end)
    chunks = data.draw(st.lists(st.one_of(st.binary(max_size=300), st.builds(_mutate, st.data())),
                                min_size=1, max_size=4))
    for chunk in chunks:
        far_end.send(chunk)
    clock.sleep(0.0)  # the scheduler polls the transport: Codec.decode on every chunk
    _assert_registry_holds_only_valid_values(link)
    TRIED["gcs"] += 1
    link.close()


def _assert_registry_holds_only_valid_values(link: Link) -> None:
    """Whatever arrived, what the GCS now believes passed validation: nothing out of range got in."""
    for view in link.registry.vehicles.values():
        assert view.lat_deg is None or (-90 <= view.lat_deg <= 90 and -180 <= view.lon_deg <= 180)
        assert all(isinstance(s.latch, Latch) and 1 <= s.slot <= 4 for s in view.slots.values())
        assert isinstance(view.primitive.primitive, Primitive) and isinstance(view.primitive.progress, Progress)
        assert math.isfinite(view.primitive.distance_to_go_m) and view.primitive.distance_to_go_m >= 0
    table = link.registry.mussels
    assert np.all(table.state < len(MusselState)) and np.all((table.battery_frac >= 0) & (table.battery_frac <= 1))
    assert np.all(np.abs(table.lat_e7) <= 90 * 10**7) and np.all(table.ids > 0)


VEHICLE_CLOCK = VirtualClock()
_vehicle_end, _fuzz_end = memory_pair()
VEHICLE = SitlVehicle(_vehicle_end, ApadParams(), *HOME, system_id=SYSID)
VEHICLE.attach(VEHICLE_CLOCK.scheduler)


@FUZZ
@given(st.data())
def test_sitl_vehicle_survives_any_bytes(data: st.DataObject) -> None:
    chunks = data.draw(st.lists(st.one_of(st.binary(max_size=300), st.builds(_mutate, st.data())),
                                min_size=1, max_size=4))
    for chunk in chunks:
        _fuzz_end.send(chunk)
    VEHICLE.poll()
    VEHICLE_CLOCK.sleep(0.01)
    _fuzz_end.receive()  # drop its answers
    # poll() catches what a handler raises (the vehicle lives on); here a handler bug must still show.
    assert not [k for k in VEHICLE.dropped if k.startswith("handler_error")], VEHICLE.dropped
    TRIED["sitl"] += 1


def test_the_counters_see_bad_and_unknown_frames() -> None:
    codec = Codec(250, 190)
    good = VALID_FRAMES[0]
    broken = bytearray(good)
    broken[-1] ^= 0xFF
    assert codec.decode(bytes(broken)) == []
    assert codec.decode(b"\x00garbage\x01") == []
    assert len(codec.decode(good)) == 1  # a good frame after garbage still parses
    assert codec.decode(_unknown_id_frame(60123, b"abc")) == []
    assert codec.stats.bad_data >= 1 and codec.stats.unknown == 1


_INT_RANGES = {"uint8_t": (0, 2**8 - 1), "int8_t": (-(2**7), 2**7 - 1), "uint16_t": (0, 2**16 - 1),
               "int16_t": (-(2**15), 2**15 - 1), "uint32_t": (0, 2**32 - 1), "int32_t": (-(2**31), 2**31 - 1),
               "uint64_t": (0, 2**64 - 1), "int64_t": (-(2**63), 2**63 - 1)}
_HOSTILE_FLOATS = st.one_of(st.floats(allow_nan=True, allow_infinity=True, width=32),
                            st.sampled_from([math.nan, math.inf, -math.inf, -1.0, 1e30]))


def _field(ftype: str, length: int) -> st.SearchStrategy[object]:
    if ftype == "char":
        return st.binary(max_size=length)
    base = st.floats(width=32, allow_nan=True) if ftype in ("float", "double") else None
    if base is not None:
        scalar: st.SearchStrategy[object] = _HOSTILE_FLOATS
    else:
        lo, hi = _INT_RANGES[ftype]
        scalar = st.one_of(st.integers(lo, hi), st.sampled_from([lo, hi, 0]))
    return st.lists(scalar, min_size=length, max_size=length) if length else scalar


def _hostile(cls: type) -> st.SearchStrategy[object]:
    """Any message of `cls` with every field drawn over its whole wire range (NaN, inf, extremes)."""
    lengths = dict(zip(cls.fieldnames, (cls.array_lengths[cls.ordered_fieldnames.index(f)]
                                        for f in cls.fieldnames), strict=True))
    fields = [_field(t, lengths[f]) for f, t in zip(cls.fieldnames, cls.fieldtypes, strict=True)]
    return st.tuples(*fields).map(lambda values: cls(*values))


# Every message the GCS reads (gcs.link.telemetry), from an aPad it already knows.
READ_BY_GCS = [mavlink.mavlink_map[i] for i in (
    mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, mavlink.MAVLINK_MSG_ID_PRIMITIVE_STATUS,
    mavlink.MAVLINK_MSG_ID_DOCK_SLOT_STATUS, mavlink.MAVLINK_MSG_ID_SYS_STATUS, mavlink.MAVLINK_MSG_ID_HOME_POSITION,
    mavlink.MAVLINK_MSG_ID_PARAM_VALUE, mavlink.MAVLINK_MSG_ID_STATUSTEXT, mavlink.MAVLINK_MSG_ID_COMMAND_ACK,
    mavlink.MAVLINK_MSG_ID_AMUSSEL_STATUS, mavlink.MAVLINK_MSG_ID_HEARTBEAT)]


@FUZZ
@given(st.lists(st.one_of(*(_hostile(cls) for cls in READ_BY_GCS)), min_size=1, max_size=8))
def test_gcs_reads_valid_frames_with_hostile_values_without_believing_them(msgs: list[object]) -> None:
    """Valid CRCs, insane fields: every message reaches the GCS's readers, none gets past validation."""
    clock = VirtualClock()
    gcs_end, far_end = memory_pair()
    link = Link(clock)
    link.add_transport(gcs_end)
    apad = Codec(SYSID, 1)
    far_end.send(apad.encode(mavlink.MAVLink_heartbeat_message(11, 3, 0, 4, 4, 3)))  # a known aPad
    for msg in msgs:
        far_end.send(apad.encode(msg))
    clock.sleep(0.0)
    assert link._pollers[0].codec.stats.received == len(msgs) + 1  # all decoded: the readers saw them
    _assert_registry_holds_only_valid_values(link)
    link.close()
