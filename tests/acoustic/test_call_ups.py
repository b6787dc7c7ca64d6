"""Call-ups over the GCS's nanomodem in the aPads' TDMA slots: what goes on the water stays in the aPad's
slot (a sleeper's ping and call-up in one), a call-up no longer wanted is abandoned only before one went,
and several aPads' loops take turns on the one unit (a try holds it until its answers; another aPad's
waits for it and then for its own next slot). Real bytes through the emulator, its pipe and the driver;
the loops as `missiontime.processes` scripts on one virtual clock, as a swarm mission runs them."""

from __future__ import annotations

from functools import partial
from itertools import pairwise

import numpy as np
import pytest

from acoustic.channel import Transmission
from acoustic.nanomodem.driver import ModemDriver, Result
from acoustic.nanomodem.emulator import LOCAL, ModemEmulator, RemoteUnit
from acoustic.nanomodem.lockstep import attach
from acoustic.nanomodem.ports import pipe
from acoustic.orders import CALL_UP_TRIES
from acoustic.params import AcousticParams
from acoustic.tdma import Owner, tdma_frame
from gcs.acoustic_net.call_ups import CallUp, CallUps
from gcs.records.events import EventLog
from missiontime import Clock
from missiontime.clocks import VirtualClock
from missiontime.processes import Processes


def test_two_apads_calling_up_at_once_take_turns_on_the_unit() -> None:
    # aPad 1 calls up an aMussel 5 km off (out of range: each try waits for #TO, about 4 s, longer than
    # a slot), aPad 2 one 20 m off, both at once. aPad 2's slot comes while aPad 1's answer is awaited.
    params = AcousticParams()
    clock = VirtualClock()
    remotes = (RemoteUnit(7, (5000.0, 0.0, 3.0)), RemoteUnit(8, (-20.0, 0.0, 3.0)))
    gcs_end, modem_end = pipe()
    attach(ModemEmulator(params, remotes, np.random.default_rng(1)), modem_end, clock)
    tdma = tdma_frame([7, 8], [1, 2], 50.0, params)  # the aPads' slots are the last two, back to back
    events = EventLog()
    call_ups = CallUps(ModemDriver(gcs_end, clock), clock, events, tdma)
    exchanges: list[tuple[int, float, float]] = []  # (aPad, start, end) of each exchange on the unit
    real_unicast_ack = call_ups.driver.unicast_ack

    def timed_unicast_ack(address: int, data: bytes) -> Result:
        holder = call_ups.holder
        assert holder is not None  # nobody speaks on the unit without holding it
        start = clock.time()
        result = real_unicast_ack(address, data)
        exchanges.append((holder, start, clock.time()))
        return result

    call_ups.driver.unicast_ack = timed_unicast_ack  # type: ignore[method-assign]
    processes = Processes(clock)
    handles = {apad: processes.spawn(f"apad{apad}", partial(call_up, call_ups, mussel, apad))
               for apad, mussel in ((1, 7), (2, 8))}
    processes.run()

    assert handles[1].result is CallUp.UNACKED and handles[2].result is CallUp.ACKED
    assert call_ups.counts["call_ups_unacked"] == 1 and call_ups.counts["call_ups_acked"] == 1
    assert call_ups.counts["modem_busy_waits"] == CALL_UP_TRIES  # each of aPad 1's tries outlasts a slot
    assert [e.fields for e in events.events if e.kind == "call_up_unacked"] == [
        {"mussel": 7, "tries": CALL_UP_TRIES, "apad": 1}]
    assert all(end - start > tdma.slot_s for apad, start, end in exchanges if apad == 1)
    for (_, _, end), (_, start, _) in pairwise(exchanges):
        assert start >= end  # one exchange on the unit at a time
    for apad, start, _ in exchanges:  # each at the start of one of its aPad's slots
        assert start == pytest.approx(tdma.next_slot_start_s(Owner.APAD, apad, start - 1e-3), abs=1e-6)
    assert [apad for apad, _, _ in exchanges] == [1] * CALL_UP_TRIES + [2]
    assert not call_ups.driver.dropped  # no reply taken by the wrong try


def test_a_call_up_no_longer_wanted_when_its_slot_comes_is_abandoned_unsent() -> None:
    # A fleet's frame can be minutes long: an aMussel believed near empty when the call-up was decided
    # may be believed empty by the aPad's slot. Nothing goes on the water then, and the loop is told.
    params = AcousticParams()
    clock = VirtualClock()
    core = ModemEmulator(params, (RemoteUnit(7, (20.0, 0.0, 3.0)),), np.random.default_rng(1))
    gcs_end, modem_end = pipe()
    attach(core, modem_end, clock)
    tdma = tdma_frame([7], [1], 50.0, params)
    events = EventLog()
    call_ups = CallUps(ModemDriver(gcs_end, clock), clock, events, tdma)
    slot_s = tdma.next_slot_start_s(Owner.APAD, 1, 0.0)
    assert slot_s > 1.0
    outcome = call_ups.call_up(7, lambda: True, 1, wanted=lambda: clock.time() < slot_s - 0.5)  # a sleeper
    assert outcome is CallUp.ABANDONED and clock.time() == pytest.approx(slot_s, abs=1e-6)
    assert call_ups.counts == {"call_ups_abandoned": 1, "call_ups_from_gcs_unit": 1}  # no ping, no call-up sent
    assert not any(core.medium.counts.values())  # nothing on the water
    assert [(e.kind, e.fields) for e in events.events] == [("call_up_abandoned", {"mussel": 7})]
    assert call_ups.call_up(7, lambda: False, 1) is CallUp.ACKED  # wanted by default: sent and acknowledged


class OneUnit:
    """The GCS's unit and one remote aMussel `at_m` away on the emulator, with every packet the GCS's
    unit puts on the water recorded (start, airtime)."""

    def __init__(self, at_m: float) -> None:
        self.params, self.clock = AcousticParams(), VirtualClock()
        self.core = ModemEmulator(self.params, (RemoteUnit(7, (at_m, 0.0, 3.0)),), np.random.default_rng(1))
        gcs_end, modem_end = pipe()
        attach(self.core, modem_end, self.clock)
        self.tdma = tdma_frame([7], [1], 50.0, self.params)
        self.events = EventLog()
        self.call_ups = CallUps(ModemDriver(gcs_end, self.clock), self.clock, self.events, self.tdma)
        self.sent: list[tuple[float, float]] = []
        transmit = self.core.medium.transmit

        def recorded(sender: int, start_s: float, payload_bytes: int, data: object = None,
                     listeners: list[int] | None = None) -> Transmission:
            tx = transmit(sender, start_s, payload_bytes, data, listeners)
            if sender == LOCAL:
                self.sent.append((tx.start_s, tx.airtime_s))
            return tx

        self.core.medium.transmit = recorded  # type: ignore[method-assign]

    def in_apad_slots(self) -> bool:
        """Every packet of the GCS's unit began and ended within one of the aPad's slots."""
        slot_s = self.tdma.slot_s
        return all(start + airtime <= self.tdma.next_slot_start_s(Owner.APAD, 1, start - slot_s) + slot_s
                   and start >= self.tdma.next_slot_start_s(Owner.APAD, 1, start - slot_s) - 1e-6
                   for start, airtime in self.sent)


def test_a_woken_sleeper_is_called_up_in_the_same_slot_as_its_ping() -> None:
    unit = OneUnit(20.0)
    assert unit.call_ups.call_up(7, lambda: True, 1) is CallUp.ACKED
    assert unit.call_ups.counts == {"wake_pings": 1, "call_up_sent": 1, "call_ups_acked": 1, "call_up_retries": 0,
                                    "call_ups_from_gcs_unit": 1}
    assert len(unit.sent) == 2 and unit.in_apad_slots()  # the ping and the call-up, one slot
    (ping_s, _), (call_s, _) = unit.sent
    assert unit.tdma.next_slot_start_s(Owner.APAD, 1, call_s - unit.tdma.slot_s) == pytest.approx(ping_s)


def test_a_sleeper_that_answers_no_ping_gets_no_call_up_outside_the_apads_slot() -> None:
    # 5 km off: no ping is answered (#TO after 4 s, past the slot). Each try ends with its ping; the last
    # sends the call-up alone at its slot's start (heard asleep, it would be taken at the next wake).
    unit = OneUnit(5000.0)
    assert unit.call_ups.call_up(7, lambda: True, 1) is CallUp.UNACKED
    counts = unit.call_ups.counts
    assert counts["wake_pings"] == CALL_UP_TRIES - 1 and counts["wake_ping:timeout"] == CALL_UP_TRIES - 1
    assert counts["call_up_sent"] == 1 and counts["call_ups_unacked"] == 1
    assert len(unit.sent) == CALL_UP_TRIES and unit.in_apad_slots()


@pytest.mark.parametrize("at_m", [500.0, 1000.0])
def test_a_ping_answered_too_late_in_the_slot_leaves_the_call_up_to_a_later_slot(at_m: float) -> None:
    # 500 m: the answer comes with too little of the slot left for the call-up and its acknowledgement;
    # 1000 m: after the slot has ended. Neither sends the call-up then: the last try sends it alone at its
    # slot's start (the modem acknowledges it; asleep, the aMussel would take it at its next wake).
    unit = OneUnit(at_m)
    assert unit.call_ups.call_up(7, lambda: True, 1) is CallUp.ACKED
    counts = unit.call_ups.counts
    assert counts["wake_pings"] == counts["call_up:no_room_after_ping"] == CALL_UP_TRIES - 1
    assert counts["call_up_sent"] == 1 and counts["call_up_retries"] == 0  # a ping alone is no retry
    assert len(unit.sent) == CALL_UP_TRIES and unit.in_apad_slots()


def test_a_call_up_that_went_is_not_abandoned_when_no_longer_wanted() -> None:
    # Out of range: the first call-up goes and is not acknowledged; it may still have been heard, so
    # the tries go on though the aMussel is no longer wanted, and the loop's surfacing wait decides.
    unit = OneUnit(5000.0)
    tries: list[float] = []

    def wanted() -> bool:
        tries.append(unit.clock.time())
        return len(tries) <= 2  # asked before the first try and at its slot: wanted; never again

    assert unit.call_ups.call_up(7, lambda: False, 1, wanted=wanted) is CallUp.UNACKED
    assert len(tries) == 2 and unit.call_ups.counts["call_up_sent"] == CALL_UP_TRIES
    assert "call_ups_abandoned" not in unit.call_ups.counts


def call_up(call_ups: CallUps, mussel: int, apad: int, own: Clock) -> CallUp:
    return call_ups.call_up(mussel, lambda: False, apad, own.sleep)
