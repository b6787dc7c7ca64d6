"""The GCS's end of the acoustic network, over its nanomodem (`acoustic.nanomodem.driver`).

- **Reports heard.** As the unit writes them (a poller of the mission scheduler), the packets it
  heard are read; each status report (`acoustic.status_packet`) becomes what the GCS knows of that
  aMussel (a `MusselView` folded into the registry, as an AMUSSEL_STATUS would be), timed when it
  was sent (its arrival less its airtime). A packet that is not a report, or a report older than
  what is known (WiFi from the surface overtook it), is dropped and counted by reason (`dropped`).
- **Call-ups.** `call_up` sends the call-up as an acknowledged unicast in the aPad's slot (to a
  sleeper right after its wake-up ping, in the same slot), retried to `CALL_UP_TRIES`; each outcome is
  counted, and one never acknowledged is an event (`call_up_unacked`): the aMussel may still have
  heard it, so the loop's surfacing wait decides.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Callable
from enum import Enum

from acoustic.airtime import airtime_s
from acoustic.nanomodem.driver import ModemDriver, Result
from acoustic.nanomodem.ports import PipeEnd
from acoustic.orders import CALL_UP, CALL_UP_TRIES
from acoustic.status_packet import SIZE, PacketError, unpack
from acoustic.tdma import Owner, TdmaFrame
from gcs.link.registry import VehicleRegistry
from gcs.link.telemetry import MusselView, lat_lon_ok
from gcs.records.events import EventLog
from missiontime import US_PER_S, Clock, Scheduler, seconds_to_us
from missiontime.clocks import Doorbell
from mussel_sim.battery import to_millivolts
from mussel_sim.vocabulary import MusselState

REPORT_AIRTIME_US = seconds_to_us(airtime_s(SIZE))
SLOT_WAIT_STEP_US = 1_000_000  # a wait for the aPad's slot passes in steps this long (a quit is heard between)
MODEM_BUSY_POLL_S = 0.5  # another aPad's loop waiting for the unit looks this often
CALL_UP_AIRTIME_S = airtime_s(len(CALL_UP))
ACK_AIRTIME_S = airtime_s(0)  # the acknowledgement: a command packet
ACOUSTIC_SOURCE = 0  # the registry's sender of what was heard acoustically (not a MAVLink system)


class CallUp(Enum):
    ACKED = "acked"  # its modem acknowledged the call-up
    UNACKED = "unacked"  # no acknowledgement after every try: it may still have heard one
    ABANDONED = "abandoned"  # no longer wanted (believed empty or gone silent) before a call-up went


class AcousticUplink:
    def __init__(self, driver: ModemDriver, registry: VehicleRegistry, clock: Clock, events: EventLog,
                 tdma: TdmaFrame) -> None:
        self.driver, self.registry, self.clock, self.events, self.tdma = driver, registry, clock, events, tdma
        self.counts: Counter[str] = Counter()  # reports folded in, call-up outcomes
        self.dropped: Counter[str] = Counter()  # packets heard and not taken, by reason
        self.holder: int | None = None  # the aPad whose exchange is on the unit now

    def register(self, scheduler: Scheduler) -> None:
        """Read as a poller of the scheduler: on an in-process pipe only when the emulator wrote (its
        doorbell), on a serial port at every drain."""
        scheduler.add_poller(self)

    def ring_on(self, bell: Doorbell) -> bool:
        port = self.driver.port
        if isinstance(port, PipeEnd):
            port.bell = bell
            return True
        return False

    def fileno(self) -> int | None:
        return None

    def poll(self) -> bool:
        port = self.driver.port
        if isinstance(port, PipeEnd) and not port.waiting:  # another party's bell rang
            return False
        return self.read(self.clock.now_us) > 0

    # ---- reports
    def read(self, now_us: int) -> int:
        """Fold in the reports heard by now; how many packets were read."""
        packets = self.driver.received()
        for packet in packets:
            try:
                report = unpack(packet.data)
            except PacketError as exc:
                self.dropped[f"report:{exc.reason}"] += 1
                continue
            try:
                state = MusselState(report.state)
            except ValueError:
                self.dropped["report:state"] += 1
                continue
            lat_e7, lon_e7 = round(report.lat_deg * 1e7), round(report.lon_deg * 1e7)
            if report.mussel_id < 1 or not lat_lon_ok(lat_e7, lon_e7):  # what no aMussel sends: refused as on MAVLink
                self.dropped["report:mussel_id" if report.mussel_id < 1 else "report:lat_lon"] += 1
                continue
            sent_us = max(now_us - REPORT_AIRTIME_US, 0)
            known = self.registry.mussels.get(report.mussel_id)
            if known is not None and known.time_us >= sent_us:
                self.dropped["report:older_than_known"] += 1
                continue
            view = MusselView(report.mussel_id, lat_e7, lon_e7, report.depth_m, report.battery_frac,
                              round(float(to_millivolts(report.battery_frac))),
                              state, True, sent_us)
            refused = self.registry.apply(ACOUSTIC_SOURCE, view, now_us)
            if refused is not None:
                self.dropped[f"report:{refused}"] += 1
            else:
                self.counts["reports_heard"] += 1
        return len(packets)

    # ---- call-ups
    def call_up(self, mussel_id: int, asleep: Callable[[], bool], apad_id: int,
                wait: Callable[[float], None] | None = None, wanted: Callable[[], bool] | None = None) -> CallUp:
        """Call an aMussel up in aPad `apad_id`'s TDMA slots (the GCS's unit speaks for it): ACKED once
        its modem acknowledged the call-up. Each try starts at the start of the aPad's next slot and
        stays within it, so it crosses no aMussel's report on the water.

        - A sleeper (`asleep`, asked at each try) is pinged first; woken, it listens a few seconds
          (`mussel_sim.comms.PING_LISTEN_US`) and the call-up follows at once if the slot has room for
          it. Unanswered (or no room left), the try ends there. The last try, if no call-up has gone
          yet, sends it without a ping: heard asleep, it is taken at the sleeper's next wake.
        - `wanted` is asked before each try until a call-up has gone (from then on it may rise): False
          abandons the call-up unsent (a slot can be a frame away, minutes in a large fleet: the
          aMussel may have been believed empty meanwhile).
        - `wait`: how to pass time (default the clock's sleep): a mission loop's own, which ends the
          call-up by raising when the operator quits.

        With several aPads their loops share the one unit: a try holds it until its answers or their
        bounds; another aPad's loop waits for it to be free and then for its own next slot (each slot
        so missed counted: `modem_busy_waits`)."""
        sleep = wait or self.clock.sleep
        sent = False  # a call-up has gone on the water
        for attempt in range(1, CALL_UP_TRIES + 1):
            if not self._take_unit(apad_id, sleep, None if sent else wanted):
                return self._abandoned(mussel_id, apad_id)
            try:
                ping = asleep() and (sent or attempt < CALL_UP_TRIES)
                result = self._try(mussel_id, apad_id, ping)
            finally:
                self.holder, self.driver.sleep = None, self.clock.sleep
            if result is None:  # a sleeper not woken in this slot: no call-up went
                continue
            sent = True
            self.counts["call_up_sent"] += 1
            if result.ok:
                self.counts["call_ups_acked"] += 1
                self.counts["call_up_retries"] += attempt - 1
                return CallUp.ACKED
            self.counts[f"call_up:{result.outcome.value}"] += 1
        self.counts["call_ups_unacked"] += 1
        self.events.emit(self.clock.time(), "call_up_unacked", mussel=mussel_id, tries=CALL_UP_TRIES,
                         **self._apad_field(apad_id))
        return CallUp.UNACKED

    def _try(self, mussel_id: int, apad_id: int, ping: bool) -> Result | None:
        """One try on the unit, in the aPad's slot: the wake-up ping first if `ping`, then the call-up;
        None if it did not go (the ping unanswered, or too little of the slot left after it)."""
        if ping:
            woken = self.driver.ping(mussel_id)
            self.counts["wake_pings"] += 1
            if not woken.ok:
                self.counts[f"wake_ping:{woken.outcome.value}"] += 1
                return None
            if not self._room_for_call_up(apad_id):
                self.counts["call_up:no_room_after_ping"] += 1
                return None
        return self.driver.unicast_ack(mussel_id, CALL_UP)

    def _room_for_call_up(self, apad_id: int) -> bool:
        """Whether a call-up and its acknowledgement, across the whole area, still end in the aPad's
        slot that began at or before now."""
        now = self.clock.time()
        slot_end = self.tdma.next_slot_start_s(Owner.APAD, apad_id, now - self.tdma.slot_s) + self.tdma.slot_s
        return now + CALL_UP_AIRTIME_S + ACK_AIRTIME_S + 2 * self.tdma.delay_s <= slot_end

    def _abandoned(self, mussel_id: int, apad_id: int) -> CallUp:
        self.counts["call_ups_abandoned"] += 1
        self.events.emit(self.clock.time(), "call_up_abandoned", mussel=mussel_id, **self._apad_field(apad_id))
        return CallUp.ABANDONED

    def _apad_field(self, apad_id: int) -> dict[str, int]:
        return {"apad": apad_id} if len(self.tdma.apad_ids) > 1 else {}

    def _take_unit(self, apad_id: int, sleep: Callable[[float], None], wanted: Callable[[], bool] | None) -> bool:
        """The unit held for `apad_id` at the start of one of its slots (the caller frees it); False,
        and not held, if it is no longer `wanted`, now or at that slot."""
        if wanted is not None and not wanted():
            return False
        while True:
            while self.holder is not None:
                sleep(MODEM_BUSY_POLL_S)
            self._wait_for_slot(apad_id, sleep)
            if self.holder is None:
                break
            self.counts["modem_busy_waits"] += 1  # another aPad's try began meanwhile: the next slot
        if wanted is not None and not wanted():
            return False
        self.holder, self.driver.sleep = apad_id, sleep
        return True

    def _wait_for_slot(self, apad_id: int, sleep: Callable[[float], None]) -> None:
        start_us = math.ceil(self.tdma.next_slot_start_s(Owner.APAD, apad_id, self.clock.time()) * US_PER_S)
        while (left_us := start_us - self.clock.now_us) > 0:  # in steps, so a quit is heard within one
            sleep(min(left_us, SLOT_WAIT_STEP_US) / US_PER_S)

    def summary(self) -> dict[str, object]:
        """For result.json: the frame, what was heard and sent, what was dropped and why."""
        return {"frame_s": round(self.tdma.frame_s, 4), "slot_s": round(self.tdma.slot_s, 4),
                "slots": self.tdma.table(), "counts": dict(sorted(self.counts.items())),
                "dropped": dict(sorted((self.dropped + Counter(self.driver.dropped)).items()))}
