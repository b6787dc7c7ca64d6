"""Docking alone: `Docking` on a recording host, an `ApadState`, a registry, its aMussel table and a
real geofence; no vehicle.

AMUSSEL_STATUS frames feed the table (bad ones counted); Dock and Undock start the latches or are
refused with a reason in result_param2 and a STATUSTEXT; as a listener of the primitive it logs
each slot that changed and reports a dock whose latch reopened.
"""

from __future__ import annotations

from dataclasses import replace

import pytest
from test_sitl_part_host import RecordingHost, Registry

from apad_sitl.docking import Docking, MusselFixTable
from apad_sitl.geofence import Geofence
from apad_sitl.params import ApadParams
from apad_sitl.primitives import Refusal, SlotState
from apad_sitl.state import ApadState
from apad_sitl.vehicle import VehicleState
from apad_sitl.vocabulary import Latch, Primitive, Progress
from mavlink_dialect import MAV_CMD_APAD_DOCK, MAV_CMD_APAD_UNDOCK, mavlink
from mussel_sim.geo import LocalFrame
from mussel_sim.vocabulary import MusselState

HOME = (43.94, 15.44)
ACCEPTED, DENIED = mavlink.MAV_RESULT_ACCEPTED, mavlink.MAV_RESULT_DENIED


class Bench:
    def __init__(self, fence_m: float | None = None) -> None:
        self.host = RecordingHost()
        self.apad = ApadState(ApadParams())
        self.commands = Registry()
        self.frame = LocalFrame(*HOME)
        fence = None
        if fence_m is not None:
            d = fence_m
            fence = Geofence.of([self.latlon(x, y) for x, y in ((0, -d), (d, -d), (d, d), (0, d))], self.frame)
        table = MusselFixTable(self.frame, self.host.dropped)
        self.docking = Docking(self.host, self.apad, self.commands, table, fence)
        self.apad.on_primitive(self.docking.slots_changed)

    def latlon(self, x_m: float, y_m: float) -> tuple[float, float]:
        lat, lon = self.frame.to_geodetic(x_m, y_m)
        return float(lat), float(lon)

    def status(self, mussel_id: int, x_m: float, y_m: float, state: int = MusselState.FLOATING) -> None:
        lat, lon = self.latlon(x_m, y_m)
        self.host.receive(mavlink.MAVLink_amussel_status_message(
            0, mussel_id, round(lat * 1e7), round(lon * 1e7), 0.0, 0.8, 4080, state, 1))


@pytest.fixture
def b() -> Bench:
    return Bench()


def test_statuses_feed_the_table_and_bad_ones_are_counted(b: Bench) -> None:
    b.status(24, 0.5, 0.0)
    b.host.receive(mavlink.MAVLink_amussel_status_message(0, 31, 91 * 10**7, 0, 0.0, 0.8, 4080, 2, 1))
    assert list(b.docking.mussels) == [24]
    assert b.docking.mussels[24].x_m == pytest.approx(0.5, abs=0.02)
    assert b.host.dropped == {"invalid:AMUSSEL_STATUS:lat": 1}


def test_a_dock_in_reach_starts_the_latch_and_logs_the_slot(b: Bench) -> None:
    b.status(24, 0.5, 0.0)
    assert b.commands.run(MAV_CMD_APAD_DOCK, 2, 24).result == ACCEPTED
    p = b.apad.primitive
    assert (p.kind, p.progress, p.slot, p.mussel_id) == (Primitive.DOCK, Progress.IN_PROGRESS, 2, 24)
    assert p.slot_state(2).latch == Latch.CLOSING
    assert b.host.events == [("slot", {"slot": 2, "mussel_id": 24, "latch": "CLOSING", "charging": False})]
    assert b.host.take() == []


@pytest.mark.parametrize(("params", "refusal", "text", "counted"), [
    ((2, 77), Refusal.UNKNOWN_MUSSEL, "Dock slot 2 aMussel 77: never heard of it", None),
    ((2, 40), Refusal.OUT_OF_REACH, "Dock slot 2 aMussel 40: out of docking reach", None),
    ((5, 24), Refusal.BAD_SLOT, "Dock slot 5 aMussel 24: slot must be 1..4", "param1"),
    ((1, float("nan")), Refusal.BAD_MUSSEL_ID, "Dock slot 1 aMussel -1: bad aMussel id", "param2"),
])
def test_a_refused_dock_says_why(b: Bench, params: tuple[float, float], refusal: Refusal, text: str,
                                 counted: str | None) -> None:
    b.status(24, 0.5, 0.0)
    b.status(40, 30.0, 0.0)
    reply = b.commands.run(MAV_CMD_APAD_DOCK, *params)
    assert (reply.result, reply.param2, reply.invalid) == (DENIED, refusal, counted)
    assert [m.text for m in b.host.take()] == [text]
    assert b.apad.primitive.kind == Primitive.IDLE


def test_a_latch_that_reopens_while_closing_is_a_failed_dock(b: Bench) -> None:
    b.status(24, 0.5, 0.0)
    b.commands.run(MAV_CMD_APAD_DOCK, 1, 24)
    b.host.events.clear()
    p = b.apad.primitive
    b.apad.set_primitive(replace(p, progress=Progress.FAILED, slots=(SlotState(), *p.slots[1:])))
    assert [m.text for m in b.host.take()] == ["Dock slot 1 aMussel 24 failed: out of reach"]
    assert b.host.events == [
        ("slot", {"slot": 1, "mussel_id": 0, "latch": "OPEN", "charging": False}),
        ("dock_failed", {"slot": 1, "mussel_id": 24, "reason": "out of reach"}),
    ]


def test_undock_releases_a_slot_and_never_over_land() -> None:
    b = Bench(fence_m=50.0)  # water east of home only
    b.status(24, 10.5, 0.0)
    b.apad.state = VehicleState(x_m=10.0)
    b.commands.run(MAV_CMD_APAD_DOCK, 3, 24)
    b.apad.set_primitive(replace(b.apad.primitive, progress=Progress.DONE,
                                 slots=(*b.apad.primitive.slots[:2], SlotState(24, Latch.LATCHED, True), SlotState())))
    b.apad.state = VehicleState(x_m=-10.0)
    b.host.events.clear()
    assert b.commands.run(MAV_CMD_APAD_UNDOCK, 3, 24).result == DENIED
    assert [m.text for m in b.host.take()] == ["Undock slot 3 refused: not over water"]
    assert b.host.events == [("geofence", {"what": "undock", "slot": 3})]
    b.apad.state = VehicleState(x_m=10.0)
    assert b.commands.run(MAV_CMD_APAD_UNDOCK, 3, 0).result == ACCEPTED
    p = b.apad.primitive
    assert (p.kind, p.slot, p.mussel_id, p.slot_state(3).latch) == (Primitive.UNDOCK, 3, 24, Latch.RELEASING)
    assert b.host.events[-1] == ("slot", {"slot": 3, "mussel_id": 24, "latch": "RELEASING", "charging": False})
