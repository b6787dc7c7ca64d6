"""A lockstep mission's acoustic network, composed: the channel, the aMussels' modems, the GCS's modem.

`AcousticNetwork.build` puts, on the mission clock:

- the nanomodem emulator (`acoustic.nanomodem.emulator`): the GCS's unit at the first aPad's home,
  one remote unit per aMussel (address = id), each aPad's own unit where that aPad is (addresses
  from 255 down), over a `Medium` seeded from the scenario's seed;
- the GCS's driver on an in-process byte pipe to its unit: the same driver code that speaks to a
  real unit through pyserial, reading the same bytes; and a driver for each aPad's unit, whose bytes
  go over the aPad's MAVLink (`apad_modem_port`) to its modem port, an in-process pipe to the water
  (`apad_modem_end`, which the world gives the SITL aPad);
- the aMussels' side (`mussel_sim.modems`): status reports in their TDMA slots, call-ups heard;
- the GCS's side: reports folded into what the GCS knows (`gcs.acoustic_net.uplink`), call-ups sent
  (`gcs.acoustic_net.call_ups`), over one driver;
- a `KnowledgeLedger` sampled every `SAMPLE_S`: the planner's belief against the simulator's truth.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from acoustic.nanomodem.driver import ModemDriver
from acoustic.nanomodem.emulator import ModemEmulator, RemoteUnit
from acoustic.nanomodem.host_commands import MAX_ADDRESS
from acoustic.nanomodem.lockstep import Attached, attach
from acoustic.nanomodem.ports import BytePort, PipeEnd, pipe
from acoustic.nanomodem.sea import Sea
from acoustic.params import AcousticParams
from acoustic.tdma import TdmaFrame, tdma_frame
from gcs.acoustic_net.apad_modem_port import ApadModemPort
from gcs.acoustic_net.call_ups import CallUps
from gcs.acoustic_net.knowledge import KnowledgeLedger, age_s
from gcs.acoustic_net.uplink import AcousticUplink
from gcs.link.registry import VehicleRegistry
from gcs.link.router import Link
from gcs.records.events import EventLog
from missiontime import Clock, Task
from mussel_sim.comms import FleetRunner
from mussel_sim.modems import MusselModems

GCS_ADDRESS = 0  # the GCS's unit; the aMussels' addresses are their ids (1..255)
GCS_DEPTH_M = 0.5  # the surface computer's unit hangs just below the surface
APAD_MODEM_DEPTH_M = 0.5  # an aPad's unit, under its hull
SAMPLE_S = 10.0  # belief against truth, sampled this often (mission seconds)
CHANNEL_SEED = 21  # the channel's draws, apart from the fleet's and the placement's for the same seed


class Planner(Protocol):
    """What the ledger reads of one aPad's loop (`gcs.loop.fleet_knowledge.FleetKnowledge`)."""

    def battery(self, mussel_id: int) -> float: ...

    def serves(self, mussel_id: int) -> bool: ...

    def claimed(self, mussel_id: int) -> bool: ...


def apad_unit_addresses(apad_ids: list[int], mussel_ids: list[int]) -> dict[int, int]:
    """Each aPad's unit's address: 255, 254, ... in the order of `apad_ids`; one an aMussel has is refused."""
    addresses = {sysid: MAX_ADDRESS - k for k, sysid in enumerate(apad_ids)}
    taken = sorted(set(addresses.values()) & set(mussel_ids))
    if taken:
        raise ValueError(f"acoustic scenarios keep the nanomodem addresses {min(addresses.values())}..{MAX_ADDRESS} "
                         f"for the aPads' own units: aMussel ids {taken} take them")
    return addresses


@dataclass(frozen=True)
class ApadModem:
    """An aPad's own unit on the water: its address, the aPad's end of its pipe, the GCS's port to it."""

    address: int
    modem_end: PipeEnd
    port: ApadModemPort


class AcousticNetwork:
    def __init__(self, emulator: Attached | None, modems: MusselModems, uplink: AcousticUplink, call_ups: CallUps,
                 ledger: KnowledgeLedger, registry: VehicleRegistry, fleet: FleetRunner,
                 apad_modems: dict[int, ApadModem] | None = None,
                 water_origin_m: tuple[float, float] = (0.0, 0.0)) -> None:
        """`apad_modems`: the aPads' own units, by aPad; `water_origin_m`: the GCS's unit in the fleet's frame."""
        self.emulator, self.modems, self.uplink, self.call_ups, self.ledger = emulator, modems, uplink, call_ups, ledger
        self.registry, self.fleet = registry, fleet
        self.apad_modems = dict(apad_modems or {})
        self._water_origin_m = water_origin_m
        # Each aPad's loop's view of the fleet (its own drains, sleep orders included), as it plans;
        # none yet: no loop plans, so there is no belief to sample.
        self.planners: dict[int, Planner] = {}
        self._task: Task | None = None

    @property
    def tdma(self) -> TdmaFrame:
        return self.modems.tdma

    @classmethod
    def build(cls, clock: Clock, fleet: FleetRunner, link: Link, events: EventLog, params: AcousticParams,
              apad_homes_deg: dict[int, tuple[float, float]], seed: int, area_range_m: float,
              unit: tuple[BytePort, Sea] | None = None, apad_modems: bool = True) -> AcousticNetwork:
        """The network on `clock`, from mission time now: the GCS's unit at the first aPad's home (of
        `apad_homes_deg`: each aPad's home, latitude and longitude), a slot for each aMussel and aPad,
        the channel's draws from `seed`; belief against truth is sampled once a loop `plans`. `unit`:
        the GCS's modem on a serial port and the sea its remote units are on (`vil gcs --modem --sea`:
        the aPads have no units of their own there, the GCS's speaks for them); None: the water
        emulated in-process (lockstep), the aPads' own units on it if `apad_modems` (the world's own SITL
        aPads, which it gives their modem ports; aPads it only connects to have none: the GCS's unit
        speaks for them)."""
        ids = [int(m) for m in fleet.state.ids]  # sorted: the medium's nodes follow the fleet's rows
        if ids and (ids[0] <= GCS_ADDRESS or ids[-1] > MAX_ADDRESS):
            raise ValueError(f"acoustic scenarios need aMussel ids 1..{MAX_ADDRESS} (the nanomodem's addresses)")
        apad_ids = list(apad_homes_deg)
        homes = {sysid: cls._local(fleet, deg) for sysid, deg in apad_homes_deg.items()}
        hx, hy = homes[apad_ids[0]]
        emulator: Attached | None = None
        apad_ends: dict[int, PipeEnd] = {}
        addresses: dict[int, int] = {}  # the aPads' own units' addresses, by aPad
        if unit is None:  # lockstep: the emulator in-process, its local unit the GCS's, on a byte pipe
            addresses = apad_unit_addresses(apad_ids, ids) if apad_modems else {}
            s = fleet.state
            remotes = tuple(RemoteUnit(m, (float(s.x_m[k]) - hx, float(s.y_m[k]) - hy, float(s.depth_m[k])))
                            for k, m in enumerate(ids))
            hosted = tuple(RemoteUnit(addresses[a], (homes[a][0] - hx, homes[a][1] - hy, APAD_MODEM_DEPTH_M))
                           for a in addresses)
            core = ModemEmulator(params, remotes, np.random.default_rng([seed, CHANNEL_SEED]),
                                 address=GCS_ADDRESS, position_m=(0.0, 0.0, GCS_DEPTH_M), hosted=hosted)
            gcs_end, modem_end = pipe()
            pipes = {a: pipe() for a in addresses}  # (the aPad's modem port, the water's end)
            emulator = attach(core, modem_end, clock, hosted=tuple(pipes[a][1] for a in addresses))
            apad_ends = {a: pipes[a][0] for a in addresses}
            port: BytePort = gcs_end
            sea: Sea = emulator
        else:
            port, sea = unit
        tdma = tdma_frame(ids, apad_ids, area_range_m, params)
        modems = MusselModems(fleet, sea, tdma, GCS_ADDRESS, (hx, hy))
        modems.register(clock.scheduler, clock.now_us)
        driver = ModemDriver(port, clock, params.sound_speed_mps)
        uplink = AcousticUplink(driver, link.registry, clock, tdma)
        uplink.register(clock.scheduler)
        own = {a: ApadModem(addresses[a], end, ApadModemPort(link, a, clock)) for a, end in apad_ends.items()}
        apad_units = {a: ModemDriver(m.port, clock, params.sound_speed_mps) for a, m in own.items()}
        network = cls(emulator, modems, uplink, CallUps(driver, clock, events, tdma, apad_units),
                      KnowledgeLedger(fleet.state.ids), link.registry, fleet, own, (hx, hy))
        network._task = clock.scheduler.every(SAMPLE_S, network.sample, "acoustic-knowledge", clock.now_us)
        return network

    @staticmethod
    def _local(fleet: FleetRunner, deg: tuple[float, float]) -> tuple[float, float]:
        x, y = fleet.frame.to_local(np.array([deg[0]]), np.array([deg[1]]))
        return float(x[0]), float(y[0])

    def place_apad_unit(self, apad_id: int, position_deg: tuple[float, float]) -> None:
        """aPad `apad_id`'s own unit where the aPad is now (its modem port calls this before each write)."""
        modem = self.apad_modems.get(apad_id)
        if self.emulator is None or modem is None:
            return
        x, y = self._local(self.fleet, position_deg)
        hx, hy = self._water_origin_m
        self.emulator.move([modem.address], np.array([[x - hx, y - hy, APAD_MODEM_DEPTH_M]]))

    def close(self) -> None:
        """Let go of the serial port and the sea's socket (an in-process pipe has nothing to free)."""
        self.uplink.driver.port.close()
        close = getattr(self.modems.sea, "close", None)
        if close is not None:
            close()

    def sample(self, now_us: int) -> None:
        """Belief against truth now, for every aMussel of the fleet; nothing before a loop plans (a
        restored mission's first instants: the loop that knows its sleep orders is not built yet) or
        after the mission's end."""
        end_us = self.fleet.end_us
        if not self.planners or (end_us is not None and now_us > end_us):
            return  # past the mission's end the fleet's model stops (uptime's span) while the loops wind up
        self.fleet.bring_up_to(now_us)  # the event platform steps the model only where it changes: the truth now
        s = self.fleet.state
        ids = s.ids.tolist()
        table = self.registry.mussels
        known = np.array([m in table for m in ids], dtype=bool)
        belief = np.array([self.belief(m) if k else 0.0 for m, k in zip(ids, known, strict=True)])
        age = np.array([age_s(table[m], now_us) if k else 0.0 for m, k in zip(ids, known, strict=True)])
        self.ledger.sample(known, belief, s.battery_frac, age)

    def plans(self, apad_id: int, planner: Planner) -> None:
        """aPad `apad_id`'s loop plans on `planner`'s belief from now on (belief against truth)."""
        self.planners[apad_id] = planner

    def belief(self, mussel_id: int) -> float:
        """The battery the planner believes: as the aPad serving that aMussel believes it (with
        several), or the aPad holding a claim on it (docked on a lost aPad: its claim holds a while,
        and the new owner does not serve it yet), else the first aPad's loop."""
        planners = self.planners.values()
        chosen = (next((p for p in planners if p.serves(mussel_id)), None)
                  or next((p for p in planners if p.claimed(mussel_id)), None) or next(iter(planners)))
        return chosen.battery(mussel_id)

    def summary(self) -> dict[str, object]:
        channel = {} if self.emulator is None else dict(self.emulator.core.medium.counts)  # else: in `vil modem`
        sea = dict(getattr(self.modems.sea, "dropped", {}))  # a sea over UDP, or none: what it did not carry
        counts = {**self.uplink.counts, **self.call_ups.counts}  # apart: reports heard; tries and outcomes
        # What crossed each aPad's MAVLink to its modem, and what its port dropped (a link that loses
        # and repeats shows here as requests asked again and output taken once)
        units = {str(a): {"messages_sent": m.port.sent, "dropped": dict(sorted(m.port.dropped.items()))}
                 for a, m in self.apad_modems.items()}
        return {**self.uplink.summary(), "counts": dict(sorted(counts.items())),
                **({"apad_units": units} if units else {}),
                "fleet": dict(sorted(self.modems.counts.items())),
                "channel": channel, "knowledge": self.ledger.summary().as_dict(),
                **({"sea_dropped": dict(sorted(sea.items()))} if sea else {})}
