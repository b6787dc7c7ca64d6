"""The simulated aMussels' nanomodems: a status report in each one's TDMA slot, call-ups heard.

Acoustic scenarios only (`[acoustic] enabled`). Each aMussel is a remote unit of the nanomodem
emulator (`acoustic.nanomodem`), its address its id, reached through a `Sea`: the emulator in-process
in lockstep, or `vil modem --sea` beside a GCS on a serial unit. The GCS's unit is the emulator's
local unit; positions go to the sea in metres from it (x east, y north, z down).

- In its slot of the TDMA frame (`acoustic.tdma`) an aMussel in the water (ACTIVE, SURFACING,
  SINKING) that has been awake since its previous slot sends its status report
  (`acoustic.status_packet`, 31 bytes) to the GCS's unit as a unicast; the channel decides whether
  it arrives. At the surface it speaks over WiFi (MAVLink) instead (`CommsConfig.wifi_at_surface_only`),
  and a depleted one says nothing: its modem has no power (`Sea.power`), so it hears no ping or
  call-up and acknowledges none either.
- A call-up (an acknowledged unicast of `acoustic.orders.CALL_UP`) heard by an aMussel becomes a
  SURFACE command at the fleet's next step; a ping heard wakes a sleeper (the wake-up ping), so a
  call-up after it is taken at once. The fleet still lets it rise only with an aPad within acoustic
  range: the permission the paper's aMussels wait for.

The modems move with their aMussels: before each report the sea takes the fleet's positions.
"""

from __future__ import annotations

from collections import Counter

import numpy as np

from acoustic.nanomodem.emulator import FrameKind
from acoustic.nanomodem.sea import Sea
from acoustic.orders import CALL_UP
from acoustic.status_packet import StatusReport, pack
from acoustic.tdma import Owner, TdmaFrame
from missiontime import US_PER_S, Scheduler, Task, seconds_to_us
from mussel_sim.comms import FleetRunner
from mussel_sim.fleet_sleep import publish_rows
from mussel_sim.vocabulary import MusselCommand, MusselState

# Heard in the water column or on the seabed: these report in their slot; at the surface they use WiFi,
# and a depleted one is silent wherever it is (the GCS learns it by its silence and its estimate).
UNDERWATER = (MusselState.ACTIVE, MusselState.SURFACING, MusselState.SINKING)


class MusselModems:
    """The fleet's side of the acoustic network, through `sea`; the GCS's unit sits at `gcs_xy_m` of the
    fleet's frame."""

    def __init__(self, fleet: FleetRunner, sea: Sea, tdma: TdmaFrame, gcs_address: int,
                 gcs_xy_m: tuple[float, float]) -> None:
        self.fleet, self.sea, self.tdma = fleet, sea, tdma
        self.gcs_address = gcs_address
        self._origin = np.array([gcs_xy_m[0], gcs_xy_m[1], 0.0])
        self._seq: dict[int, int] = {}
        self.counts: Counter[str] = Counter()  # reports sent, slots silent by reason, frames heard by kind
        self._slot = 0
        self._unpowered: set[int] = set()  # the aMussels whose modem the sea has without power
        self._task: Task | None = None
        sea.listen(self._heard)

    def register(self, scheduler: Scheduler, start_us: int = 0) -> Task:
        """A task at every slot's start from mission time `start_us` on. The frame runs from mission time
        0 whenever the fleet joins it, as the GCS's uplink counts it (`TdmaFrame.next_slot_start_s`): a
        mission restored from a checkpoint keeps the slots where they were, or a call-up sent in the
        aPad's slot would cross the aMussels' reports."""
        slot_us = seconds_to_us(self.tdma.slot_s)
        self._slot = -(-start_us // slot_us)  # the first slot starting at or after `start_us`
        self._task = scheduler.every(self.tdma.slot_s, self._slot_task, "tdma-slot", self._slot * slot_us)
        return self._task

    def _slot_task(self, now_us: int) -> None:
        slot = self.tdma.slots[self._slot % len(self.tdma.slots)]
        self._slot += 1
        self._follow_power()
        if slot.owner is not Owner.AMUSSEL:
            return  # the aPads' slots: they send nothing yet
        self.fleet.bring_up_to(now_us)  # the event platform's model steps only at changes
        s = self.fleet.state
        k = int(np.searchsorted(s.ids, slot.node_id))
        if k >= s.n or int(s.ids[k]) != slot.node_id:
            self.counts["silent:not_in_fleet"] += 1
            return
        if MusselState(int(s.state[k])) not in UNDERWATER:
            self.counts["silent:at_surface_or_depleted"] += 1
            return
        since_us = now_us - round(self.tdma.frame_s * US_PER_S)
        rows = publish_rows(s, self.fleet.params.theta, since_us, now_us)
        if rows is not None and k not in rows:
            self.counts["silent:asleep"] += 1
            return
        self._follow_fleet()
        self.sea.send(slot.node_id, pack(self._report(k, now_us)), self.gcs_address)
        self.counts["reports_sent"] += 1

    def _report(self, k: int, now_us: int) -> StatusReport:
        s, fleet = self.fleet.state, self.fleet
        mussel_id = int(s.ids[k])
        seq = self._seq.get(mussel_id, -1) + 1 & 0xFF
        self._seq[mussel_id] = seq
        lat, lon = fleet.frame.to_geodetic(s.x_m[k:k + 1], s.y_m[k:k + 1])
        r = fleet.sensors.sample(s.x_m[k:k + 1], s.y_m[k:k + 1], s.depth_m[k:k + 1], now_us / US_PER_S)
        return StatusReport(
            mussel_id=mussel_id, seq=seq, state=int(s.state[k]), battery_frac=float(s.battery_frac[k]),
            fix_time_s=now_us / US_PER_S, lat_deg=float(lat[0]), lon_deg=float(lon[0]),
            depth_m=float(s.depth_m[k]), dissolved_oxygen_mg_l=float(r.dissolved_oxygen_mg_l[0]),
            temperature_degc=float(r.temperature_degc[0]), pressure_hpa=float(r.pressure_hpa[0]),
            turbidity_ntu=float(r.turbidity_ntu[0]))

    def _follow_fleet(self) -> None:
        """The sea's remote units where the fleet is now."""
        s = self.fleet.state
        self.sea.move(s.ids.tolist(), np.column_stack([s.x_m, s.y_m, s.depth_m]) - self._origin)

    def _follow_power(self) -> None:
        """The sea's modems powered as their aMussels are: a depleted one's is off (told on change only)."""
        s = self.fleet.state
        off = set(s.ids[s.state == MusselState.DEPLETED].tolist())
        if off != self._unpowered:
            self.sea.power({m: m not in off for m in off ^ self._unpowered})
            self.counts["modems_powered_off"] += len(off - self._unpowered)
            self._unpowered = off

    def _heard(self, address: int, kind: FrameKind, data: bytes) -> None:
        """What an aMussel's modem heard addressed to it: a call-up, or a ping that wakes it."""
        self.counts[f"heard:{kind.value}"] += 1
        if kind is FrameKind.PING:
            self.fleet.heard_acoustically(address, None)
        elif kind is FrameKind.UNICAST_ACK and data == CALL_UP:
            self.fleet.heard_acoustically(address, MusselCommand.SURFACE)
