"""The GCS's end of the acoustic network, over its nanomodem (`acoustic.nanomodem.driver`).

- **Reports heard.** As the unit writes them (a poller of the mission scheduler), the packets it
  heard are read; each status report (`acoustic.status_packet`) becomes what the GCS knows of that
  aMussel (a `MusselView` folded into the registry, as an AMUSSEL_STATUS would be), timed when it
  was sent (its arrival less its airtime). A packet that is not a report, or a report older than
  what is known (WiFi from the surface overtook it), is dropped and counted by reason (`dropped`).

The call-ups go out through the same unit: `gcs.acoustic_net.call_ups`.
"""

from __future__ import annotations

from collections import Counter

from acoustic.airtime import airtime_s
from acoustic.nanomodem.driver import ModemDriver
from acoustic.nanomodem.ports import PipeEnd
from acoustic.status_packet import SIZE, PacketError, unpack
from acoustic.tdma import TdmaFrame
from gcs.link.registry import VehicleRegistry
from gcs.link.telemetry import MusselView, lat_lon_ok
from missiontime import Clock, Scheduler, seconds_to_us
from missiontime.clocks import Doorbell
from mussel_sim.battery import to_millivolts
from mussel_sim.vocabulary import MusselState

REPORT_AIRTIME_US = seconds_to_us(airtime_s(SIZE))
ACOUSTIC_SOURCE = 0  # the registry's sender of what was heard acoustically (not a MAVLink system)


class AcousticUplink:
    def __init__(self, driver: ModemDriver, registry: VehicleRegistry, clock: Clock, tdma: TdmaFrame) -> None:
        self.driver, self.registry, self.clock, self.tdma = driver, registry, clock, tdma
        self.counts: Counter[str] = Counter()  # reports folded in
        self.dropped: Counter[str] = Counter()  # packets heard and not taken, by reason

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

    def summary(self) -> dict[str, object]:
        """For result.json: the frame, what was heard and sent, what was dropped and why."""
        return {"frame_s": round(self.tdma.frame_s, 4), "slot_s": round(self.tdma.slot_s, 4),
                "slots": self.tdma.table(), "counts": dict(sorted(self.counts.items())),
                "dropped": dict(sorted((self.dropped + Counter(self.driver.dropped)).items()))}
