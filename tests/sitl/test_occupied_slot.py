"""A Dock into a slot that already holds the aMussel (Listing 1 run twice): refused with a reason the
GCS reads, never accepted with nothing to report; a latch still closing is followed again instead."""

from __future__ import annotations

import pytest
from test_gcs_api import lockstep, offset

from apad_sitl.primitives import Refusal
from apad_sitl.vocabulary import Latch, Primitive, Progress
from gcs.link.apad_api import CommandError
from mavlink_dialect import mavlink

pytestmark = pytest.mark.sitl


def test_a_dock_into_a_slot_latched_from_before_is_refused_slot_occupied() -> None:
    w = lockstep()
    w.api.docking(True, 2, 11)
    assert w.wait_primitive() == Progress.DONE
    w.api.go_to(offset(0.0, -5.0))  # the aPad moves on (the first script ended; a second one starts)
    assert w.wait_primitive() == Progress.DONE
    with pytest.raises(CommandError) as err:
        w.api.docking(True, 2, 11)
    assert err.value.result == mavlink.MAV_RESULT_DENIED and err.value.reason == Refusal.SLOT_OCCUPIED
    assert err.value.words == "slot 2 occupied" and "slot 2 occupied" in str(err.value)
    # The refusal changed nothing: the Go To is still what the API follows, and it is done (no hang).
    assert w.api.docking_status(w.apad_id) == Progress.DONE
    slot = w.api.slots(w.apad_id)[1]
    assert (slot.mussel_id, slot.latch) == (11, Latch.LATCHED)
    assert "slot occupied" in " ".join(w.api.apad(w.apad_id).statustext)


def test_a_repeat_of_the_dock_in_force_is_accepted_and_changes_nothing() -> None:
    w = lockstep()
    w.api.docking(True, 2, 11)
    assert w.wait_primitive() == Progress.DONE
    w.api.docking(True, 2, 11)  # still the primitive in force: a re-send, answered as before
    assert w.wait_primitive() == Progress.DONE
    assert w.vehicle.primitive.kind == Primitive.DOCK


def test_a_dock_repeated_after_a_hold_over_its_closing_latch_is_followed_to_its_end() -> None:
    w = lockstep()
    w.api.docking(True, 1, 11)
    w.api.hold()  # an operator's override while the latch closes: the latch carries on
    assert w.vehicle.primitive.slot_state(1).latch == Latch.CLOSING
    w.api.docking(True, 1, 11)  # the loop takes over again: the Dock is reported on, to its end
    assert w.wait_primitive() == Progress.DONE
    assert w.api.slots(w.apad_id)[0].mussel_id == 11 and w.api.slots(w.apad_id)[0].latch == Latch.LATCHED
