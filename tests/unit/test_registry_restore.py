"""A mission resumed from its checkpoint knows what the saved registry knew: the vehicles and the
aMussel table, and also when each aMussel was heard, when the fleet last spoke and when a slot let go
of an aMussel (what the foresight of a released aMussel reads), in the objects others hold."""

from __future__ import annotations

import pickle

from apad_sitl.vocabulary import Latch
from gcs.link.registry import VehicleRegistry
from gcs.link.telemetry import Heartbeat, MusselView, SlotView
from mussel_sim.vocabulary import MusselState


def test_a_restored_registry_keeps_when_things_were_heard_and_let_go_in_place() -> None:
    saved = VehicleRegistry()
    saved.apply(2, Heartbeat(custom_mode=0, armed=True), 1_000_000)
    saved.apply(250, MusselView(7, 439_000_000, 154_000_000, 0.0, 0.5, 3_900, MusselState.DOCKED, False, 2_000_000),
                3_000_000)
    saved.apply(2, SlotView(1, 7, Latch.LATCHED), 4_000_000)
    saved.apply(2, SlotView(1, 0, Latch.OPEN), 5_000_000)
    assert saved.released_us == {7: 5_000_000} and saved.mussel_heard_us == {7: 3_000_000}

    resumed = VehicleRegistry()
    heard_by_others = resumed.mussel_heard_us  # a real fleet's estimates hold this dict (`RealFleet`)
    resumed.restore(pickle.loads(pickle.dumps(saved)))
    assert resumed.mussel_heard_us is heard_by_others and heard_by_others == {7: 3_000_000}
    assert resumed.released_us == {7: 5_000_000} and resumed.fleet_heard_us == 3_000_000
    assert resumed.mussels[7].state == MusselState.DOCKED and 2 in resumed.vehicles
