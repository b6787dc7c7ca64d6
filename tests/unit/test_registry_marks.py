"""The registry's marks (`VehicleRegistry.marks`) move with every change a wait reads of an aPad, and only
then: a wait builds what it reads again only when they moved (`FleetKnowledge.news`), so a mark that stayed
put over a change would leave a wait asleep, and one that moves at every report would cost what it saves."""

from __future__ import annotations

from dataclasses import replace

from apad_sitl.vocabulary import Latch, Primitive, Progress
from gcs.link.registry import VehicleRegistry
from gcs.link.telemetry import Battery, Charging, Heartbeat, Position, PrimitiveView, SlotView

APAD = 2
GOTO = PrimitiveView(Primitive.GOTO, Progress.IN_PROGRESS, 439_000_000, 154_000_000, 30.0, 0.0)


def registry() -> VehicleRegistry:
    r = VehicleRegistry(ideal=True)
    r.apply(APAD, Heartbeat(custom_mode=0, armed=True), 0)
    r.watch_battery(APAD, "low", lambda v: v < 12.0)
    return r


def moved_by(r: VehicleRegistry, record: object) -> tuple[int, int]:
    """(changed, moved): how far each counter went on applying `record`."""
    before = r.marks(APAD, True)
    r.apply(APAD, record, 1_000_000)  # type: ignore[arg-type]  # any record the registry takes
    after = r.marks(APAD, True)
    return after[0] - before[0], after[1] - before[1]


def test_where_the_apad_is_and_how_far_its_go_to_has_gone_move_only_the_moves_mark() -> None:
    r = registry()
    assert moved_by(r, GOTO) == (1, 1)  # a new primitive: news to every wait
    assert moved_by(r, Position(43.9, 15.4, 90.0)) == (0, 1)
    assert moved_by(r, replace(GOTO, distance_to_go_m=20.0, distance_travelled_m=10.0)) == (0, 1)
    assert moved_by(r, replace(GOTO, progress=Progress.DONE)) == (1, 1)
    assert r.marks(APAD, False)[1] == 0  # a wait that does not read the moves compares the first alone


def test_a_battery_moves_a_mark_only_across_a_threshold_a_wait_reads() -> None:
    r = registry()
    assert moved_by(r, Battery(15.0, 90)) == (1, 0)  # the first: the threshold's answer is known only now
    news = r.news
    assert moved_by(r, Battery(14.9, 89)) == (0, 0) and r.news == news  # no news at all
    assert moved_by(r, Battery(11.9, 20)) == (1, 0)
    r.watch_battery(APAD, "full", lambda v: v >= 16.0)
    assert r.marks(APAD, False)[0] > 0 and moved_by(r, Battery(11.8, 19)) == (0, 0)


def test_every_other_report_and_what_we_expect_move_the_changed_mark() -> None:
    r = registry()
    for record in (SlotView(1, 7, Latch.CLOSING), Charging(True), Heartbeat(custom_mode=4, armed=True)):
        assert moved_by(r, record) == (1, 0)
    before = r.marks(APAD, False)
    r.expect(APAD, Primitive.GOTO, GOTO.target_lat_e7, GOTO.target_lon_e7)
    assert r.marks(APAD, False)[0] == before[0] + 1
    assert moved_by(r, GOTO) == (1, 1)  # the expected primitive seen: news though the status is the one before
    r.expect_again(APAD, None)
    assert r.marks(APAD, False)[0] == before[0] + 3
