"""The nanomodem emulator's pure core: units on host serial lines, remote units on the water.

`ModemEmulator` takes a host's bytes with their arrival times (`from_host`) and is advanced to an
instant (`advance`), returning the bytes the local unit writes by then (`take_output` for another
hosted unit's); `next_due_s` says when it next has something to do (the edge sleeps until then).
The local unit is the one a `vil modem` pty or the GCS's driver speaks to; more hosted units
(`hosted`: the aPads' own modems, each reached over its aPad's MAVLink) share its water. Between
units go `Frame`s over a `Medium`, so delay, loss, half duplex and collisions are the channel
model's. The remote units answer as the real ones do: a ping or an acknowledged unicast with a
reply, `$V` with their voltage, `$E` with the data back; a unit answers as soon as the request has
arrived (`TURNAROUND_S`). A remote unit without power (`set_power`: its aMussel depleted) hears
nothing and answers nothing. Pure: no clock, no I/O.

Where the unit's guide is silent (NOTES.md), the emulator's reading: `$V` and `$M` unanswered give
`#TO` after the same 4 s as a ping; `$T` sends a command packet the remote counts; an echo comes
back as a unicast (`#Unn<data>`); `$Q` before any packet, or after one that failed to decode, is
`$C-`, else the mean number of wrong coded bytes at the packet's SNR (0-8); a command that would
queue more than `MAX_QUEUED_S` of packets behind the one on the water is answered `E` (`busy`).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import Enum

import numpy as np

from acoustic.airtime import PING_TIMEOUT_S, RANGE_TICK_S, airtime_s
from acoustic.channel import Medium, Outcome, Reception, Transmission
from acoustic.nanomodem.grammar import STRAY, Rejected
from acoustic.nanomodem.host_commands import GAP_S, MAX_ADDRESS, Command, CommandParser, Kind
from acoustic.nanomodem.replies import (
    MAX_TICKS,
    VOLTS_PER_TICK,
    Ack,
    AddressSet,
    Error,
    Quality,
    Range,
    Received,
    Reply,
    Status,
    Timeout,
)
from acoustic.params import AcousticParams
from acoustic.per import expected_byte_errors

TURNAROUND_S = 0.0
# Packets the local unit queues behind the one it is sending, in seconds of airtime; a command that
# would queue more is answered `E` and counted (`busy`): a host that writes faster than the water
# carries cannot grow the emulator without bound.
MAX_QUEUED_S = 4.5
LOCAL = 0  # the local unit's node index in the medium; remote unit i is node i + 1, hosted unit j n + 1 + j


class FrameKind(Enum):
    PING = "ping"
    PING_REPLY = "ping_reply"
    VOLTAGE_REQUEST = "voltage_request"
    VOLTAGE_REPLY = "voltage_reply"
    BROADCAST = "broadcast"
    UNICAST = "unicast"
    UNICAST_ACK = "unicast_ack"
    ACK = "ack"
    TEST = "test"
    ECHO = "echo"


ANSWERS = {FrameKind.PING: FrameKind.PING_REPLY, FrameKind.UNICAST_ACK: FrameKind.ACK,
           FrameKind.VOLTAGE_REQUEST: FrameKind.VOLTAGE_REPLY}


@dataclass(frozen=True)
class Frame:
    kind: FrameKind
    source: int  # the sending unit's address
    dest: int | None  # None: to all
    data: bytes = b""


@dataclass(frozen=True)
class RemoteUnit:
    address: int
    position_m: tuple[float, float, float]  # x east, y north, z down
    supply_v: float = 12.0


@dataclass
class Wait:
    """An answer the local unit waits for: a reply of `kind` from `address` by `deadline_s`."""

    kind: FrameKind
    address: int
    sent_s: float
    first_leg_s: float  # the request's airtime
    deadline_s: float


HEARD_KEPT = 1024  # the newest frames the remote units heard, kept for tests and the records


@dataclass
class HeardLog:
    """What the remote units heard (time, address, frame): the newest HEARD_KEPT, and how many in all."""

    entries: deque[tuple[float, int, Frame]] = field(default_factory=lambda: deque(maxlen=HEARD_KEPT))
    total: int = 0


def supply_ticks(volts: float) -> int:
    return int(min(max(round(volts / VOLTS_PER_TICK), 0), 65535))


@dataclass
class HostedUnit:
    """A unit on a host's serial line: its node on the water, address, the commands it is parsing,
    the answers it waits for, the quality of the last packet it decoded, the bytes it has written."""

    node: int
    address: int
    supply_v: float
    parser: CommandParser
    waits: list[Wait] = field(default_factory=list)
    quality: int | None = None
    out: bytearray = field(default_factory=bytearray)


class ModemEmulator:
    def __init__(
        self, params: AcousticParams, remotes: tuple[RemoteUnit, ...], rng: np.random.Generator, *,
        address: int = 0, position_m: tuple[float, float, float] = (0.0, 0.0, 0.0), supply_v: float = 12.0,
        gap_s: float = GAP_S, ping_timeout_s: float = PING_TIMEOUT_S, hosted: tuple[RemoteUnit, ...] = (),
    ) -> None:
        """`hosted`: more units on host serial lines (index 1, 2, ... of `from_host` and `take_output`),
        after the remote units on the water; they move with `move_remotes` like the remote units."""
        addresses = [r.address for r in (*remotes, *hosted)]
        if len(set(addresses)) != len(addresses) or any(not 0 <= a <= MAX_ADDRESS for a in addresses):
            raise ValueError(f"remote and hosted addresses must differ and be 0..{MAX_ADDRESS}, got {addresses}")
        self.params, self.remotes = params, remotes
        # address -> node index in the medium of the remote units, and of the hosted units' starting
        # addresses (what `move_remotes` moves; `$A` gives a hosted unit a new address, not a new place)
        self._nodes = {r.address: i + 1 for i, r in enumerate(remotes)}
        self._movable = {**self._nodes, **{h.address: len(remotes) + 1 + j for j, h in enumerate(hosted)}}
        self.ping_timeout_s = ping_timeout_s
        positions = np.array([position_m, *(r.position_m for r in (*remotes, *hosted))], dtype=np.float64)
        self.medium = Medium(params, positions, rng)
        self.units = [HostedUnit(LOCAL, address, supply_v, CommandParser(gap_s))]
        self.units += [HostedUnit(self._movable[h.address], h.address, h.supply_v, CommandParser(gap_s))
                       for h in hosted]
        self._hosted_at = {u.node: u for u in self.units}  # node -> the hosted unit there
        self.heard = HeardLog()
        # What a remote unit heard addressed to it (or to all) is also handed here: (end s, address, frame).
        self.on_remote_heard: Callable[[float, int, Frame], None] | None = None
        self.counts: dict[str, int] = {}
        self.unpowered: set[int] = set()  # addresses of remote units without power

    @property
    def address(self) -> int:
        """The local unit's address (`$A` changes it)."""
        return self.units[0].address

    # ---- the serial side
    def from_host(self, data: bytes, t_s: float, unit: int = 0) -> None:
        """Bytes hosted unit `unit`'s host wrote (0: the local unit's), arrived at `t_s` (call
        `advance(t_s)` first, so time runs in order)."""
        u = self.units[unit]
        for item in u.parser.feed(data, t_s):
            self._command(u, item, t_s)

    def advance(self, t_s: float) -> bytes:
        """Run to `t_s`; the bytes the local unit has written to its host since the last call (the
        other hosted units' wait in `take_output`)."""
        self.run_to(t_s)
        return self.take_output(0)

    def run_to(self, t_s: float) -> None:
        """Run to `t_s`; what the hosted units write waits in `take_output`."""
        while (due := self.next_due_s()) is not None and due <= t_s:
            self._step(due)
        self._step(t_s)

    def take_output(self, unit: int) -> bytes:
        """The bytes hosted unit `unit` has written to its host and nobody has taken yet."""
        u = self.units[unit]
        out, u.out = bytes(u.out), bytearray()
        return out

    def next_due_s(self) -> float | None:
        times = [t for t in (*(u.parser.deadline_s() for u in self.units), self.medium.next_decision_s())
                 if t is not None]
        times += [w.deadline_s for u in self.units for w in u.waits]
        return min(times, default=None)

    def remote_send(self, address: int, t_s: float, data: bytes, dest: int | None = None) -> Transmission:
        """Remote unit `address` sends `data` at `t_s`: a broadcast, or a unicast to `dest`."""
        node = self._node_of(address)
        kind = FrameKind.BROADCAST if dest is None else FrameKind.UNICAST
        return self._send(node, t_s, Frame(kind, address, dest, data))

    def move_remotes(self, addresses: list[int], positions_m: np.ndarray) -> None:
        """Remote units to new positions (metres, the local unit's frame); an unknown address is counted."""
        nodes = self.medium.positions_m.copy()
        for address, position in zip(addresses, np.asarray(positions_m, dtype=np.float64).reshape(-1, 3), strict=True):
            node = self._movable.get(address)
            if node is None:
                self.count("move_unknown_unit")
                continue
            nodes[node] = position
        self.medium.move(nodes)

    def set_power(self, powered: dict[int, bool]) -> None:
        """Remote units' power (address -> has it): one without hears and answers nothing; an unknown
        address is counted."""
        for address, on in powered.items():
            if address not in self._nodes:
                self.count("power_unknown_unit")
            elif on:
                self.unpowered.discard(address)
            else:
                self.unpowered.add(address)

    def count(self, reason: str) -> None:
        """One more of `reason` in `counts` (the edges count what happened to their ports here too)."""
        self.counts[reason] = self.counts.get(reason, 0) + 1

    @staticmethod
    def _reply(unit: HostedUnit, reply: Reply) -> None:
        unit.out += reply.encode()

    def _node_of(self, address: int) -> int:
        node = self._nodes.get(address)
        if node is None:
            raise KeyError(f"no remote unit {address}")
        return node

    def _send(self, node: int, t_s: float, frame: Frame) -> Transmission:
        start = max(t_s, self.medium.busy_until_s(node))
        return self.medium.transmit(node, start, len(frame.data), frame, self._listeners(frame))

    def _listeners(self, frame: Frame) -> list[int] | None:
        """The nodes that act on `frame` on time: all for a broadcast, else its addressee (if any unit has it)."""
        if frame.dest is None:
            return None
        nodes = [u.node for u in self.units if u.address == frame.dest]  # a hosted unit may share a remote's
        node = self._nodes.get(frame.dest)
        return nodes if node is None else [*nodes, node]

    def _command(self, unit: HostedUnit, item: Command | Rejected, t_s: float) -> None:
        if isinstance(item, Rejected):
            self.counts[item.reason] = self.counts.get(item.reason, 0) + item.weight
            if item.reason != STRAY:
                self._reply(unit, Error())
            return
        self.count("command")
        kind, a = item.kind, item.address
        if kind is Kind.SET_ADDRESS:
            assert a is not None
            unit.address = a
            self._reply(unit, AddressSet(a))
        elif kind is Kind.STATUS:
            self._reply(unit, Status(unit.address, supply_ticks(unit.supply_v)))
        elif kind is Kind.QUALITY:
            self._reply(unit, Quality(unit.quality))
        elif self.medium.busy_until_s(unit.node) > t_s + MAX_QUEUED_S:
            self.count("busy")
            self._reply(unit, Error())
        else:
            assert kind is Kind.BROADCAST or a is not None
            self._reply(unit, Ack(kind, a, len(item.data) if kind.has_data else None))
            frame_kind = {Kind.PING: FrameKind.PING, Kind.VOLTAGE: FrameKind.VOLTAGE_REQUEST,
                          Kind.BROADCAST: FrameKind.BROADCAST, Kind.UNICAST: FrameKind.UNICAST,
                          Kind.UNICAST_ACK: FrameKind.UNICAST_ACK, Kind.TEST: FrameKind.TEST,
                          Kind.ECHO: FrameKind.ECHO}[kind]
            tx = self._send(unit.node, t_s, Frame(frame_kind, unit.address, a, item.data))
            if frame_kind in ANSWERS and a is not None:
                # The unit's 4 s run from its own transmission: a request queued behind packets already
                # on the water must not time out before it is sent.
                unit.waits.append(Wait(ANSWERS[frame_kind], a, tx.start_s, tx.airtime_s,
                                        tx.start_s + self.ping_timeout_s))

    # ---- the water side
    def _step(self, t_s: float) -> None:
        for unit in self.units:
            for item in unit.parser.expire(t_s):
                self._command(unit, item, t_s)
        for reception in self.medium.settle(t_s):
            self._reception(reception)
        for unit in self.units:
            for wait in [w for w in unit.waits if w.deadline_s <= t_s]:
                unit.waits.remove(wait)
                self.count("timeout")
                self._reply(unit, Timeout())

    def _reception(self, r: Reception) -> None:
        frame = r.transmission.data
        assert isinstance(frame, Frame)
        unit = self._hosted_at.get(r.receiver)
        if r.outcome is not Outcome.DELIVERED:
            self.count(f"{'remote' if unit is None else 'local'}_{r.outcome.value}")
            if unit is not None:
                unit.quality = None
            return
        if unit is not None:
            unit.quality = min(round(expected_byte_errors(r.snr_db, len(frame.data), self.params)), 8)
            self._local_heard(unit, frame, r)
        else:
            self._remote_heard(self.remotes[r.receiver - 1], r.receiver, frame, r)

    def _local_heard(self, unit: HostedUnit, frame: Frame, r: Reception) -> None:
        if frame.kind is FrameKind.BROADCAST:
            self.count("heard")
            self._reply(unit, Received(frame.data, frame.source))
            return
        if frame.dest != unit.address:
            self.count("not_for_us")
            return
        if frame.kind in (FrameKind.UNICAST, FrameKind.UNICAST_ACK, FrameKind.ECHO):
            self.count("heard")
            self._reply(unit, Received(frame.data))
        if frame.kind in ANSWERS:  # another unit's request of this one: answered, nothing printed
            self._answer(unit.node, unit.address, frame, r)
            return
        wait = next((w for w in unit.waits if w.kind is frame.kind and w.address == frame.source), None)
        if wait is None:
            if frame.kind in ANSWERS.values():
                self.count("late_answer")
            return
        unit.waits.remove(wait)
        if frame.kind is FrameKind.VOLTAGE_REPLY:
            self._reply(unit, Received(frame.data, frame.source))
            return
        answer_s = airtime_s(len(frame.data))
        one_way_s = (r.end_s - wait.sent_s - wait.first_leg_s - answer_s - TURNAROUND_S) / 2.0
        self._reply(unit, Range(frame.source, int(min(max(round(one_way_s / RANGE_TICK_S), 0), MAX_TICKS))))

    def _remote_heard(self, unit: RemoteUnit, node: int, frame: Frame, r: Reception) -> None:
        if frame.dest is not None and frame.dest != unit.address:
            return
        if unit.address in self.unpowered:
            self.count("remote_unpowered")
            return
        self.heard.entries.append((r.end_s, unit.address, frame))
        self.heard.total += 1
        if self.on_remote_heard is not None:
            self.on_remote_heard(r.end_s, unit.address, frame)
        self._answer(node, unit.address, frame, r)

    def _answer(self, node: int, address: int, frame: Frame, r: Reception) -> None:
        """A unit's automatic answer to a request it heard (after `TURNAROUND_S`)."""
        t = r.end_s + TURNAROUND_S
        if frame.kind in ANSWERS:
            hosted = self._hosted_at.get(node)
            volts = hosted.supply_v if hosted is not None else self.remotes[node - 1].supply_v
            data = f"V{supply_ticks(volts):05d}".encode() if frame.kind is FrameKind.VOLTAGE_REQUEST else b""
            self._send(node, t, Frame(ANSWERS[frame.kind], address, frame.source, data))
        elif frame.kind is FrameKind.ECHO:
            self._send(node, t, Frame(FrameKind.UNICAST, address, frame.source, frame.data))

