"""A seeded UDP proxy that drops, delays, duplicates and reorders datagrams, both ways.

    GCS --udp--> [gcs side | FaultProxy | vehicle side] --udp--> aPad

The sockets are real; the delays are in mission time on the run's clock. The proxy is two
scheduler pollers (one per socket, so a wall clock can `select` on both) plus one task that
fires when the earliest held datagram falls due. In lockstep that keeps runs repeatable: the
same seed and faults give the same drops and delays whatever the CPU does, and a 200 ms latency
costs 200 ms of mission time, not of wall time. On a wall clock the same code is a field proxy.

Reordering is what jitter does: each datagram draws its own delay, so a later one may overtake.
At most `MAX_HELD` datagrams wait in the proxy; past that one is dropped and counted (`overflow`),
after its draws, so a bound that bites does not reshuffle the faults that follow. Both sockets
bind loopback unless given an address; the GCS side forgets a GCS silent for 30 s of mission time.
"""

from __future__ import annotations

import heapq
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from mavlink_dialect.transport import UdpTransport
from missiontime import US_PER_S, Clock, Task, seconds_to_us, us_to_s

_IDLE_PERIOD_US = 3600 * US_PER_S  # the delivery task sleeps this long when nothing is held
MAX_HELD = 65_536  # datagrams in flight; 200 ms of a pool12 mission holds a few dozen


@dataclass(frozen=True)
class LinkFaults:
    """What the proxy does to every datagram, each way independently."""

    loss_frac: float = 0.0  # probability a datagram is dropped
    latency_s: float = 0.0  # fixed one-way delay, mission seconds
    jitter_s: float = 0.0  # extra delay drawn uniformly from [0, jitter_s]; reorders datagrams
    duplicate_frac: float = 0.0  # probability a datagram is sent twice (the copy has its own delay)
    seed: int = 0
    outages_s: tuple[tuple[float, float], ...] = ()  # (start, end) mission-time windows of total loss

    def __post_init__(self) -> None:
        for name in ("loss_frac", "duplicate_frac"):
            value = getattr(self, name)
            if not 0.0 <= value < 1.0:
                raise ValueError(f"{name.removesuffix('_frac')} must be a fraction in [0, 1), got {value}")
        for name in ("latency_s", "jitter_s"):
            if getattr(self, name) < 0.0:
                raise ValueError(f"{name.removesuffix('_s')} must not be negative")
        for start, end in self.outages_s:
            if not 0.0 <= start < end:
                raise ValueError(f"an outage must be START:END with 0 <= START < END, got {start}:{end}")

    @property
    def any(self) -> bool:
        return bool(self.loss_frac or self.latency_s or self.jitter_s or self.duplicate_frac or self.outages_s)

    def in_outage(self, t_s: float) -> bool:
        return any(start <= t_s < end for start, end in self.outages_s)


@dataclass
class ProxyStats:
    forwarded: int = 0
    dropped: int = 0
    duplicated: int = 0
    reordered: int = 0  # delivered before a datagram that entered the proxy earlier (same way)
    overflow: int = 0  # dropped because MAX_HELD datagrams were already waiting
    no_peer: int = 0  # due, but nobody to send it to (no GCS heard in the last 30 s)


@dataclass(order=True)
class _Held:
    due_us: int
    seq: int
    data: bytes = field(compare=False)
    to_vehicle: bool = field(compare=False)


class _Side:
    """One UDP transport of the proxy, polled by the scheduler: what it receives goes the other way."""

    def __init__(self, admit: Callable[[bytes, bool], None], transport: UdpTransport, to_vehicle: bool) -> None:
        self.admit, self.transport, self.to_vehicle = admit, transport, to_vehicle

    def poll(self) -> bool:
        chunks = self.transport.receive()
        for data in chunks:
            self.admit(data, self.to_vehicle)
        return bool(chunks)

    def fileno(self) -> int | None:
        return self.transport.fileno()


class FaultProxy:
    """Listens for the GCS on `listen_port` (0: any free port) and forwards to the vehicle's address."""

    def __init__(self, clock: Clock, vehicle_addr: tuple[str, int], faults: LinkFaults,
                 listen_host: str = "127.0.0.1", listen_port: int = 0) -> None:
        self.clock = clock
        self.faults = faults
        self.vehicle_addr = vehicle_addr
        self.stats = {True: ProxyStats(), False: ProxyStats()}  # to vehicle / to GCS
        self._rng = np.random.default_rng(faults.seed)
        self._held: list[_Held] = []
        self.max_held = MAX_HELD
        self._seq = 0
        self._last_seq = {True: -1, False: -1}
        # The GCS side listens and answers whoever spoke; the vehicle side sends to the vehicle.
        gcs_udp = UdpTransport(listen_host, listen_port, listen=True, now_s=clock.time)  # mission time: repeatable
        self.gcs_side = _Side(self._admit, gcs_udp, to_vehicle=True)
        self.vehicle_side = _Side(self._admit, UdpTransport(*vehicle_addr, listen=False), to_vehicle=False)
        sched = clock.scheduler
        self._task: Task = sched.every(us_to_s(_IDLE_PERIOD_US), self._deliver_due, "faultproxy.deliver",
                                       clock.now_us + _IDLE_PERIOD_US)
        sched.add_poller(self.gcs_side)
        sched.add_poller(self.vehicle_side)

    @property
    def listen_port(self) -> int:
        return self.gcs_side.transport.local_port

    def _admit(self, data: bytes, to_vehicle: bool) -> None:
        f = self.faults
        stats = self.stats[to_vehicle]
        # Four draws per datagram whatever happens, so one fault's setting never shifts another's.
        lost, dup, j1, j2 = self._rng.random(4)
        if lost < f.loss_frac or (f.outages_s and f.in_outage(self.clock.time())):
            stats.dropped += 1
            return
        copies = [j1]
        if dup < f.duplicate_frac:
            copies.append(j2)
            stats.duplicated += 1
        now_us = self.clock.now_us
        for jitter in copies:
            if len(self._held) >= self.max_held:
                stats.overflow += 1
                continue
            due_us = now_us + seconds_to_us(f.latency_s + f.jitter_s * float(jitter))
            heapq.heappush(self._held, _Held(due_us, self._seq, data, to_vehicle))
            self._seq += 1
        if not self._held:
            return
        head = self._held[0].due_us
        if head < self._task.next_us:
            self.clock.scheduler.reschedule(self._task, next_us=head)
        if head <= now_us:
            self._deliver_due(now_us)  # no delay: forward in the same instant

    def _deliver_due(self, now_us: int) -> None:
        held = self._held
        while held and held[0].due_us <= now_us:
            item = heapq.heappop(held)
            stats = self.stats[item.to_vehicle]
            if item.seq < self._last_seq[item.to_vehicle]:
                stats.reordered += 1
            self._last_seq[item.to_vehicle] = max(self._last_seq[item.to_vehicle], item.seq)
            out = (self.vehicle_side if item.to_vehicle else self.gcs_side).transport
            if out.peers:  # the GCS side has nobody to answer until the GCS has spoken
                out.send(item.data)
                stats.forwarded += 1
            else:
                stats.no_peer += 1
        next_us = held[0].due_us if held else now_us + _IDLE_PERIOD_US
        self.clock.scheduler.reschedule(self._task, next_us=max(next_us, now_us))

    def close(self) -> None:
        sched = self.clock.scheduler
        sched.remove_poller(self.gcs_side)
        sched.remove_poller(self.vehicle_side)
        sched.reschedule(self._task, active=False)
        self.gcs_side.transport.close()
        self.vehicle_side.transport.close()
