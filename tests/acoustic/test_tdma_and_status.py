"""The TDMA frame from a fleet and an area, and the status report's bytes."""

from __future__ import annotations

import math
import struct
from dataclasses import replace

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from acoustic.params import AcousticParams
from acoustic.status_packet import SCALES, SIZE, PacketError, StatusReport, pack, unpack
from acoustic.tdma import Owner, largest_range_m, tdma_frame

P = AcousticParams()


def test_slot_is_longest_packet_plus_largest_delay_plus_guard() -> None:
    frame = tdma_frame([3, 1, 2], [1], 300.0, P)
    assert frame.packet_s == pytest.approx(1.105) and frame.delay_s == pytest.approx(0.2)
    assert frame.slot_s == pytest.approx(1.105 + 0.2 + 0.2)
    assert frame.frame_s == pytest.approx(4 * 1.505)
    assert [(s.owner, s.node_id) for s in frame.slots] == [
        (Owner.AMUSSEL, 1), (Owner.AMUSSEL, 2), (Owner.AMUSSEL, 3), (Owner.APAD, 1)]
    assert frame.slot_of(Owner.APAD, 1).start_s == pytest.approx(3 * 1.505)
    assert frame.table()[1] == {"slot": 1, "owner": "amussel", "id": 2, "start_s": pytest.approx(1.505),
                                "end_s": pytest.approx(3.01)}
    short = tdma_frame([1], [], 300.0, replace(P, max_packet_bytes=31, guard_s=0.1))
    assert short.slot_s == pytest.approx(0.105 + 47 * 0.0125 + 0.2 + 0.1)
    with pytest.raises(KeyError):
        frame.slot_of(Owner.AMUSSEL, 9)
    with pytest.raises(ValueError, match="differ"):
        tdma_frame([1, 1], [], 10.0, P)


def test_next_slot_start_repeats_every_frame() -> None:
    frame = tdma_frame([1, 2], [7], 150.0, P)  # slot 1.405 s, frame 4.215 s
    start = frame.slot_of(Owner.AMUSSEL, 2).start_s
    assert frame.next_slot_start_s(Owner.AMUSSEL, 2, 0.0) == pytest.approx(start)
    assert frame.next_slot_start_s(Owner.AMUSSEL, 2, start) == pytest.approx(start)
    assert frame.next_slot_start_s(Owner.AMUSSEL, 2, start + 0.01) == pytest.approx(start + frame.frame_s)
    assert frame.next_slot_start_s(Owner.APAD, 7, 100.0) >= 100.0


def test_a_slot_is_whole_microseconds_so_the_fleet_and_the_gcs_keep_the_same_slots_for_months() -> None:
    frame = tdma_frame(range(1, 121), [1, 2], 1234.567, P)  # a delay of no whole microseconds
    slot_us = round(frame.slot_s * 1e6)
    assert slot_us / 1e6 == frame.slot_s and slot_us >= (frame.packet_s + frame.delay_s + frame.guard_s) * 1e6
    # 90 days on: the uplink's slot start (seconds from mission time 0) is the clock's k-th slot to the microsecond.
    t_s = 90 * 86_400.0
    start_s = frame.next_slot_start_s(Owner.APAD, 2, t_s)
    k = round(start_s / frame.slot_s)
    assert abs(start_s * 1e6 - k * slot_us) < 1.0 and k % len(frame.slots) == frame.slot_of(Owner.APAD, 2).index


def test_largest_range_of_an_area() -> None:
    square = [(0, 0), (30, 0), (30, 40), (0, 40)]
    assert largest_range_m(square) == pytest.approx(50.0)
    assert largest_range_m(square, depth_m=120.0) == pytest.approx(130.0)
    assert largest_range_m([(5, 5)]) == 0.0


REPORT = StatusReport(mussel_id=42, seq=7, state=0, battery_frac=0.734, fix_time_s=1234.0, lat_deg=43.9401234,
                      lon_deg=15.4398381, depth_m=1.85, dissolved_oxygen_mg_l=6.125, temperature_degc=21.37,
                      pressure_hpa=1199.4, turbidity_ntu=3.2)


def test_a_status_report_fits_a_packet_and_round_trips_to_its_quanta() -> None:
    data = pack(REPORT)
    assert len(data) == SIZE == 31 <= 64
    back = unpack(data)
    assert back.mussel_id == 42 and back.seq == 7 and back.state == 0 and back.fix_time_s == 1234.0
    assert back.lat_deg == pytest.approx(REPORT.lat_deg, abs=1e-7)
    assert back.battery_frac == pytest.approx(0.734, abs=1e-5)
    assert back.temperature_degc == pytest.approx(21.37) and back.pressure_hpa == pytest.approx(1199.4)
    assert pack(back) == data


def test_wild_values_clip_ids_out_of_range_are_refused_bad_payloads_are_named() -> None:
    wild = unpack(pack(replace(REPORT, battery_frac=1.7, temperature_degc=-900.0, depth_m=-3.0)))
    assert (wild.battery_frac, wild.temperature_degc, wild.depth_m) == (1.0, -327.68, 0.0)
    for bad in (replace(REPORT, mussel_id=70000), replace(REPORT, seq=256), replace(REPORT, battery_frac=math.nan)):
        with pytest.raises(ValueError):
            pack(bad)
    with pytest.raises(PacketError) as short:
        unpack(pack(REPORT)[:-1])
    assert short.value.reason == "length"
    with pytest.raises(PacketError) as version:
        unpack(b"\x02" + pack(REPORT)[1:])
    assert version.value.reason == "version"


@settings(max_examples=150, deadline=None)
@given(st.binary(min_size=SIZE - 1, max_size=SIZE - 1))
def test_any_version_1_payload_round_trips_exactly(rest: bytes) -> None:
    data = b"\x01" + rest
    assert pack(unpack(data)) == data


_FINITE = st.floats(allow_nan=False, allow_infinity=False, min_value=-1e9, max_value=1e9)


@settings(max_examples=150, deadline=None)
@given(st.integers(0, 65535), st.integers(0, 255), st.integers(0, 255), st.lists(_FINITE, min_size=9, max_size=9))
def test_any_report_packs_and_unpacks_within_a_quantum(mid: int, seq: int, state: int, values: list[float]) -> None:
    report = StatusReport(mid, seq, state, *values)
    back = unpack(pack(report))
    assert (back.mussel_id, back.seq, back.state) == (mid, seq, state)
    assert pack(back) == pack(report)  # a second trip changes nothing
    for name, (scale, (lo, hi)) in SCALES.items():
        value, got = getattr(report, name), getattr(back, name)
        clipped = min(max(value, lo / scale), hi / scale)  # a value beyond the field: its end
        assert abs(got - clipped) <= 0.5 / scale + 1e-9 * abs(clipped)
    assert struct.calcsize("<BBHBHIiiHHhIH") == SIZE
