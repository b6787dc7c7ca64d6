"""The GCS's call-ups over the aPads' nanomodems (`acoustic.nanomodem.driver`), in their TDMA slots.

`CallUps.call_up` sends the call-up as an acknowledged unicast in the aPad's slot (to a sleeper right
after its wake-up ping, in the same slot), retried to `CALL_UP_TRIES`; each outcome is counted, and one
never acknowledged is an event (`call_up_unacked`): the aMussel may still have heard it, so the loop's
surfacing wait decides.

An aPad with a modem of its own (`apad_units`: a driver over `gcs.acoustic_net.apad_modem_port`, its bytes
carried by the aPad's MAVLink) calls up from where it is: the permission comes from the aPad in range,
as the paper has it. An aPad without one (a SITL process, a console on a real unit at sea) has the
GCS's unit speak for it in its slot; with several such aPads their loops (`missiontime.processes`)
take turns on that one unit. The reports the GCS's unit hears come in through `gcs.acoustic_net.uplink`.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Callable
from enum import Enum

from acoustic.airtime import airtime_s
from acoustic.nanomodem.driver import ModemDriver, Result
from acoustic.nanomodem.replies import Range
from acoustic.orders import CALL_UP, CALL_UP_TRIES
from acoustic.tdma import Owner, TdmaFrame
from gcs.records.events import EventLog
from missiontime import US_PER_S, Clock

SLOT_WAIT_STEP_US = 1_000_000  # a wait for the aPad's slot passes in steps this long (a quit is heard between)
MODEM_BUSY_POLL_S = 0.5  # another aPad's loop waiting for the unit looks this often
CALL_UP_AIRTIME_S = airtime_s(len(CALL_UP))
ACK_AIRTIME_S = airtime_s(0)  # the acknowledgement: a command packet


class CallUp(Enum):
    ACKED = "acked"  # its modem acknowledged the call-up
    UNACKED = "unacked"  # no acknowledgement after every try: it may still have heard one
    ABANDONED = "abandoned"  # no longer wanted (believed empty or gone silent) before a call-up went


class CallUps:
    def __init__(self, driver: ModemDriver, clock: Clock, events: EventLog, tdma: TdmaFrame,
                 apad_units: dict[int, ModemDriver] | None = None) -> None:
        """`driver`: the GCS's unit; `apad_units`: the drivers of the aPads' own units, by aPad."""
        self.driver, self.clock, self.events, self.tdma = driver, clock, events, tdma
        self.apad_units = dict(apad_units or {})
        self.counts: Counter[str] = Counter()  # tries, pings and outcomes
        self.holder: int | None = None  # the aPad whose try is on the GCS's unit now

    def call_up(self, mussel_id: int, asleep: Callable[[], bool], apad_id: int,
                wait: Callable[[float], None] | None = None, wanted: Callable[[], bool] | None = None) -> CallUp:
        """Call an aMussel up in aPad `apad_id`'s TDMA slots (the GCS's unit speaks for it): ACKED once
        its modem acknowledged the call-up. Each try starts at the start of the aPad's next slot and
        stays within it, so it crosses no aMussel's report on the water.

        - A sleeper (`asleep`, asked at each try) is pinged first; woken, it listens a few seconds
          (`mussel_sim.fleet_orders.PING_LISTEN_US`) and the call-up follows at once if the slot has room for
          it. Unanswered (or no room left), the try ends there. The last try, if no call-up has gone
          yet, sends it without a ping: heard asleep, it is taken at the sleeper's next wake.
        - `wanted` is asked before each try until a call-up has gone (from then on it may rise): False
          abandons the call-up unsent (a slot can be a frame away, minutes in a large fleet: the
          aMussel may have been believed empty meanwhile).
        - `wait`: how to pass time (default the clock's sleep): a mission loop's own, which ends the
          call-up by raising when the operator quits.

        An aPad with its own unit calls up through it. APads without share the GCS's unit: a try holds
        it until its answers or their bounds; another aPad's loop waits for it to be free and then for
        its own next slot (each slot so missed counted: `modem_busy_waits`)."""
        sleep = wait or self.clock.sleep
        own = self.apad_units.get(apad_id)
        driver = own or self.driver
        self.counts["call_ups_from_apad_unit" if own else "call_ups_from_gcs_unit"] += 1
        sent = 0  # call-ups gone on the water
        for attempt in range(1, CALL_UP_TRIES + 1):
            slot_start = self._take_unit(apad_id, sleep, None if sent else wanted, shared=own is None)
            if slot_start is None:
                return self._abandoned(mussel_id, apad_id)
            driver.sleep = sleep
            try:
                ping = asleep() and (sent > 0 or attempt < CALL_UP_TRIES)
                result = self._try(driver, mussel_id, slot_start + self.tdma.slot_s, ping)
            finally:
                driver.sleep = self.clock.sleep
                if not own:
                    self.holder = None
            if result is None:  # a sleeper not woken in this slot: no call-up went
                continue
            sent += 1
            self.counts["call_up_sent"] += 1
            if result.ok:
                self.counts["call_ups_acked"] += 1
                self.counts["call_up_retries"] += sent - 1  # call-ups sent again (a ping alone is none)
                return CallUp.ACKED
            self.counts[f"call_up:{result.outcome.value}"] += 1
        self.counts["call_ups_unacked"] += 1
        self.events.emit(self.clock.time(), "call_up_unacked", mussel=mussel_id, tries=CALL_UP_TRIES,
                         **self._apad_field(apad_id))
        return CallUp.UNACKED

    def _try(self, driver: ModemDriver, mussel_id: int, slot_end_s: float, ping: bool) -> Result | None:
        """One try on `driver`'s unit, in the aPad's slot ending at `slot_end_s`: the wake-up ping first
        if `ping`, then the call-up; None if it did not go (the ping unanswered, or too little of the
        slot left after it)."""
        if ping:
            woken = driver.ping(mussel_id)
            self.counts["wake_pings"] += 1
            if not woken.ok:
                self.counts[f"wake_ping:{woken.outcome.value}"] += 1
                return None
            assert isinstance(woken.reply, Range)  # what `ModemDriver.ping` answers with
            if not self._room_for_call_up(woken.reply.range_m(driver.sound_speed_mps), slot_end_s):
                self.counts["call_up:no_room_after_ping"] += 1
                return None
        return driver.unicast_ack(mussel_id, CALL_UP)

    def _room_for_call_up(self, range_m: float, slot_end_s: float) -> bool:
        """Whether a call-up sent now to an aMussel `range_m` away, and its acknowledgement heard across
        the whole area, still end by `slot_end_s`."""
        there_s = range_m / self.driver.sound_speed_mps
        return self.clock.time() + CALL_UP_AIRTIME_S + there_s + ACK_AIRTIME_S + self.tdma.delay_s <= slot_end_s

    def _abandoned(self, mussel_id: int, apad_id: int) -> CallUp:
        self.counts["call_ups_abandoned"] += 1
        self.events.emit(self.clock.time(), "call_up_abandoned", mussel=mussel_id, **self._apad_field(apad_id))
        return CallUp.ABANDONED

    def _apad_field(self, apad_id: int) -> dict[str, int]:
        return {"apad": apad_id} if len(self.tdma.apad_ids) > 1 else {}

    def _take_unit(self, apad_id: int, sleep: Callable[[float], None], wanted: Callable[[], bool] | None,
                   shared: bool) -> float | None:
        """The start of one of `apad_id`'s slots, its unit ready to send: the GCS's unit (`shared`) held
        for it (the caller frees it), or the aPad's own. None, and not held, if it is no longer
        `wanted`, now or at that slot."""
        if wanted is not None and not wanted():
            return None
        while True:
            while shared and self.holder is not None:
                sleep(MODEM_BUSY_POLL_S)
            start_s = self._wait_for_slot(apad_id, sleep)
            if not shared or self.holder is None:
                break
            self.counts["modem_busy_waits"] += 1  # another aPad's try began meanwhile: the next slot
        if wanted is not None and not wanted():
            return None
        if shared:
            self.holder = apad_id
        return start_s

    def _wait_for_slot(self, apad_id: int, sleep: Callable[[float], None]) -> float:
        """Until the start of the aPad's next slot (now, if one starts now); that start (s)."""
        start_s = self.tdma.next_slot_start_s(Owner.APAD, apad_id, self.clock.time())
        start_us = math.ceil(start_s * US_PER_S)
        while (left_us := start_us - self.clock.now_us) > 0:  # in steps, so a quit is heard within one
            sleep(min(left_us, SLOT_WAIT_STEP_US) / US_PER_S)
        return start_s
