"""The shared water: packets in time between nodes, each reception decided once it has ended.

`Medium` holds the nodes' positions (metres: x east, y north, z down) and the packets on the water.
`transmit` puts one on (its delay and mean SNR to every node computed then, vectorised over the
nodes); `settle(now_s)` decides every reception that has ended by `now_s`, in a fixed order, so a
run is deterministic from the Generator it was given. A reception is lost:

- HALF_DUPLEX: the receiver was itself transmitting while the packet arrived;
- COLLISION: another packet, strong enough there (`interference_snr_db`), overlapped it at the
  receiver (both are lost, as in UnetStack's simple channel: no capture);
- PACKET_ERROR: the draw against `per.success_probability` at its mean SNR and payload size failed
  (read from its table: `per.success_lookup`).

A node that hears a packet below `interference_snr_db` does not hear it at all (no reception).
Pure: no clock, no I/O; time is passed in.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum

import numpy as np
from numpy.typing import NDArray

from acoustic.airtime import airtime_s
from acoustic.params import AcousticParams
from acoustic.per import success_lookup
from acoustic.propagation import delay_s, ranges_m, snr_db


class Outcome(Enum):
    DELIVERED = "delivered"
    PACKET_ERROR = "packet_error"
    COLLISION = "collision"
    HALF_DUPLEX = "half_duplex"


_BY_CODE = (Outcome.DELIVERED, Outcome.COLLISION, Outcome.HALF_DUPLEX, Outcome.PACKET_ERROR)  # `_decide`'s codes


@dataclass(frozen=True)
class Transmission:
    """One packet on the water. `payload_bytes` 0 is a ping or command packet (0.105 s)."""

    tx_id: int
    sender: int  # node index
    start_s: float
    airtime_s: float
    payload_bytes: int
    data: object  # what it carries, opaque to the channel
    range_m: NDArray[np.float64] = field(repr=False, compare=False)  # (n_nodes,) at transmit time
    arrival_s: NDArray[np.float64] = field(repr=False, compare=False)  # (n_nodes,) start of arrival
    snr_db: NDArray[np.float64] = field(repr=False, compare=False)  # (n_nodes,) mean band SNR
    p_ok: NDArray[np.float64] = field(repr=False, compare=False)  # (n_nodes,) P(decoded) at that SNR

    @property
    def end_s(self) -> float:
        return self.start_s + self.airtime_s


@dataclass(frozen=True)
class Reception:
    transmission: Transmission
    receiver: int
    start_s: float
    end_s: float
    range_m: float
    snr_db: float
    outcome: Outcome


class Medium:
    """Nodes and the packets between them. Node i's position is row i of `positions_m` (n, 3)."""

    def __init__(self, params: AcousticParams, positions_m: NDArray[np.float64], rng: np.random.Generator) -> None:
        self.params, self.rng = params, rng
        self.positions_m = np.array(positions_m, dtype=np.float64).reshape(-1, 3)
        self._on_water: list[Transmission] = []
        self._undecided: dict[int, NDArray[np.bool_]] = {}  # tx_id -> (n_nodes,) receivers still to decide
        self._first_end: dict[int, float] = {}  # tx_id -> the earliest end among its undecided receptions
        # tx_id -> (n_nodes,) the receivers whose reception must be decided as it ends (`transmit`'s
        # `listeners`), and the earliest end among those undecided (absent: none left)
        self._urgent: dict[int, NDArray[np.bool_]] = {}
        self._next_end: dict[int, float] = {}
        self._next_id = 0
        self.counts: dict[str, int] = {o.value: 0 for o in Outcome}

    @property
    def n_nodes(self) -> int:
        return int(self.positions_m.shape[0])

    def move(self, positions_m: NDArray[np.float64]) -> None:
        """New positions (same nodes); packets already on the water keep the geometry they left with."""
        positions = np.asarray(positions_m, dtype=np.float64).reshape(-1, 3)
        if positions.shape != self.positions_m.shape:
            raise ValueError(f"expected positions of shape {self.positions_m.shape}, got {positions.shape}")
        self.positions_m = positions.copy()

    def transmit(self, sender: int, start_s: float, payload_bytes: int, data: object = None,
                 listeners: list[int] | None = None) -> Transmission:
        """Put a packet on the water from node `sender` at `start_s`. `listeners`: the nodes that act
        on it (its addressee); only their receptions are decided as they end (`next_decision_s`), the
        others' at the next `settle` after theirs end (the same outcome, told later). None: every node."""
        if not 0 <= sender < self.n_nodes:
            raise ValueError(f"no node {sender} (nodes 0..{self.n_nodes - 1})")
        r = ranges_m(self.positions_m[sender], self.positions_m)
        snr = snr_db(r, self.params)
        tx = Transmission(self._next_id, sender, start_s, airtime_s(payload_bytes), payload_bytes, data,
                          r, start_s + delay_s(r, self.params), snr, success_lookup(snr, payload_bytes, self.params))
        self._next_id += 1
        hears = tx.snr_db >= self.params.interference_snr_db
        hears[sender] = False
        self._on_water.append(tx)
        if hears.any():
            self._undecided[tx.tx_id] = hears
            self._first_end[tx.tx_id] = float(np.min(tx.arrival_s[hears])) + tx.airtime_s
            urgent = hears.copy()
            if listeners is not None:
                urgent[:] = False
                urgent[listeners] = hears[listeners]
            self._urgent[tx.tx_id] = urgent
            if urgent.any():
                self._next_end[tx.tx_id] = float(np.min(tx.arrival_s[urgent])) + tx.airtime_s
        return tx

    def busy_until_s(self, node: int) -> float:
        """When `node`'s own last packet leaves the water (its transmitter is free), or -inf."""
        ends = [t.end_s for t in self._on_water if t.sender == node]
        return max(ends, default=-np.inf)

    def next_decision_s(self) -> float | None:
        """The earliest instant at which `settle` would decide a listener's reception, or None."""
        return min(self._next_end.values(), default=None)

    def settle(self, now_s: float) -> list[Reception]:
        """Every reception that has ended by `now_s`, decided; ordered by end time, packet, receiver."""
        decided: list[Reception] = []
        for tx in self._on_water:
            if self._first_end.get(tx.tx_id, np.inf) > now_s:
                continue
            pending, urgent = self._undecided[tx.tx_id], self._urgent[tx.tx_id]
            end = tx.arrival_s + tx.airtime_s
            due = pending & (end <= now_s)
            decided.extend(self._decide(tx, np.flatnonzero(due)))
            pending &= ~due
            urgent &= ~due
            if urgent.any():
                self._next_end[tx.tx_id] = float(np.min(end[urgent]))
            else:
                self._next_end.pop(tx.tx_id, None)
            if pending.any():
                self._first_end[tx.tx_id] = float(np.min(end[pending]))
            else:
                del self._undecided[tx.tx_id], self._first_end[tx.tx_id], self._urgent[tx.tx_id]
        decided.sort(key=lambda r: (r.end_s, r.transmission.tx_id, r.receiver))
        self._prune(now_s)
        return decided

    def _decide(self, tx: Transmission, receivers: NDArray[np.intp]) -> list[Reception]:
        start = tx.arrival_s[receivers]
        end = start + tx.airtime_s
        half_duplex = np.zeros(receivers.shape, dtype=bool)
        collision = np.zeros(receivers.shape, dtype=bool)
        for other in self._on_water:
            if other.tx_id == tx.tx_id:
                continue
            # The receiver's own packet: it cannot listen while it sends.
            own = receivers == other.sender
            half_duplex |= own & (other.start_s < end) & (other.end_s > start)
            o_start = other.arrival_s[receivers]
            strong = other.snr_db[receivers] >= self.params.interference_snr_db
            collision |= ~own & strong & (o_start < end) & (o_start + other.airtime_s > start)
        draws = np.asarray(self.rng.random(receivers.shape[0]))  # one per reception, in receiver order: deterministic
        codes = np.where(half_duplex, 2, np.where(collision, 1, np.where(draws < tx.p_ok[receivers], 0, 3)))
        outcomes = [_BY_CODE[c] for c in codes.tolist()]
        for outcome in outcomes:
            self.counts[outcome.value] += 1
        return [Reception(tx, node, t0, t1, r, snr, outcome) for node, t0, t1, r, snr, outcome in zip(
            receivers.tolist(), start.tolist(), end.tolist(), tx.range_m[receivers].tolist(),
            tx.snr_db[receivers].tolist(), outcomes, strict=True)]

    def _prune(self, now_s: float) -> None:
        """Drop decided packets that no reception can still overlap: those gone from the water
        everywhere before `now_s` (packets sent later arrive after it) and before the earliest
        arrival still undecided."""
        horizon = min((float(np.min(t.arrival_s)) for t in self._on_water if t.tx_id in self._undecided),
                      default=now_s)
        horizon = min(horizon, now_s)
        self._on_water = [t for t in self._on_water
                          if t.tx_id in self._undecided or float(np.max(t.arrival_s)) + t.airtime_s > horizon]
