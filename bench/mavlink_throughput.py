"""MAVLink throughput: messages per second encoded and parsed, over the in-memory pair and real UDP.

Two messages: the dialect's AMUSSEL_STATUS (the fleet's bulk traffic) and common's
GLOBAL_POSITION_INT (the aPad's). Over UDP every message is its own datagram, sent in bursts
small enough for the loopback socket buffer, so the figure is the whole send/recv/parse path.

A second table compares the batch path (`mavlink_dialect.hot`) with the per-message one for a
fleet's AMUSSEL_STATUS tick at 12, 240 and 10,000 aMussels: per message is building the pymavlink
object and `Codec.encode`; batch is `encode_batch` from numpy arrays plus `pack_datagrams`. Both
decoders read the same 1400-byte datagrams: `Codec.decode` (pymavlink objects) against
`decode_datagram` per datagram and `decode_datagrams` over the tick's datagrams (numpy arrays).
Each figure is the best of three runs (shared machines are noisy).

    .venv/bin/python bench/mavlink_throughput.py [--count N]
"""

from __future__ import annotations

import argparse
import socket
import time
from collections.abc import Callable

import numpy as np
from rich.console import Console
from rich.table import Table

from mavlink_dialect import Codec, mavlink, memory_pair, open_transport
from mavlink_dialect.hot import AMUSSEL_STATUS, encode_batch, pack_datagrams
from mavlink_dialect.hot_decode import decode_datagram, decode_datagrams
from mavlink_dialect.transport import Transport
from mussel_sim.vocabulary import MusselState

BURST = 200  # datagrams in flight at once: well inside the loopback receive buffer


def amussel_status(i: int) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_amussel_status_message(
        i * 1000, 1 + i % 500, 439400000 + i, 154400000 - i, 2.5, 0.75, 4050, MusselState.ACTIVE, 1
    )


def global_position_int(i: int) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_global_position_int_message(i, 439400000 + i, 154400000, 0, 0, 10, -5, 0, 9000)


def rate(count: int, seconds: float) -> float:
    return count / seconds if seconds > 0 else float("inf")


def bench_encode(make: Callable[[int], mavlink.MAVLink_message], count: int) -> float:
    codec = Codec(1, 1)
    msgs = [make(i) for i in range(count)]
    start = time.perf_counter()
    for msg in msgs:
        codec.encode(msg)
    return rate(count, time.perf_counter() - start)


def bench_parse(make: Callable[[int], mavlink.MAVLink_message], count: int) -> float:
    frames = [Codec(1, 1).encode(make(i)) for i in range(count)]
    rx = Codec(2, 2)
    start = time.perf_counter()
    for frame in frames:  # one datagram per parse, as the link does
        rx.decode(frame)
    elapsed = time.perf_counter() - start
    assert rx.stats.received == count
    return rate(count, elapsed)


def bench_link(
    make: Callable[[int], mavlink.MAVLink_message], count: int, tx: Transport, rx: Transport
) -> tuple[float, int]:
    """Encode, send, receive and parse `count` messages; (msgs/s, lost)."""
    enc, dec = Codec(1, 1), Codec(2, 2)
    msgs = [make(i) for i in range(count)]
    got = 0
    start = time.perf_counter()
    for first in range(0, count, BURST):
        burst = msgs[first : first + BURST]
        for msg in burst:
            tx.send(enc.encode(msg))
        want = got + len(burst)
        deadline = time.perf_counter() + 1.0
        while got < want and time.perf_counter() < deadline:
            for chunk in rx.receive():
                got += len(dec.decode(chunk))
    return rate(got, time.perf_counter() - start), count - got


FLEETS = (12, 240, 10_000)


def fleet_columns(n: int) -> dict[str, np.ndarray]:
    """One AMUSSEL_STATUS tick of `n` aMussels, the values `amussel_status` gives message by message."""
    i = np.arange(n)
    return {
        "time_us": i * 1000, "mussel_id": 1 + i % 500, "lat": 439400000 + i, "lon": 154400000 - i,
        "depth": np.full(n, 2.5), "battery": np.full(n, 0.75), "battery_voltage": np.full(n, 4050),
        "state": np.full(n, int(MusselState.ACTIVE)), "simulated": np.ones(n, np.uint8),
    }  # fmt: skip


def timed(ticks: int, tick: Callable[[], object]) -> float:
    """Seconds per tick, the best of three runs of `ticks` ticks (the machine is shared)."""
    best = float("inf")
    for _ in range(3):
        start = time.perf_counter()
        for _ in range(ticks):
            tick()
        best = min(best, (time.perf_counter() - start) / ticks)
    return best


def bench_batch(n: int, count: int) -> tuple[float, ...]:
    """msg/s for a fleet of `n`: encode 1 by 1, batch; decode 1 by 1, per datagram, all datagrams at once."""
    cols = fleet_columns(n)
    ticks = max(1, count // n)
    rows = [dict(zip(cols, values, strict=True)) for values in zip(*(c.tolist() for c in cols.values()), strict=True)]
    tx = Codec(1, 1)
    enc_one = timed(ticks, lambda: [tx.encode(mavlink.MAVLink_amussel_status_message(**r)) for r in rows])
    enc_batch = timed(ticks, lambda: pack_datagrams(encode_batch(tx, AMUSSEL_STATUS, cols)))
    grams = pack_datagrams(encode_batch(tx, AMUSSEL_STATUS, cols))
    rx = Codec(2, 2)
    dec_one = timed(ticks, lambda: [rx.decode(g) for g in grams])
    dec_gram = timed(ticks, lambda: [decode_datagram(g) for g in grams])
    dec_all = timed(ticks, lambda: decode_datagrams(grams))
    assert sum(len(decode_datagram(g).hot) for g in grams) == n == len(decode_datagrams(grams).hot)
    assert rx.stats.bad_data == 0
    return n / enc_one, n / enc_batch, n / dec_one, n / dec_gram, n / dec_all


def batch_table(count: int) -> Table:
    table = Table(title="AMUSSEL_STATUS per fleet tick: batch path vs per message (msg/s)")
    cols = ("aMussels", "encode 1 by 1", "encode batch", "ratio", "decode 1 by 1", "per datagram", "ratio",
            "all at once", "ratio")  # fmt: skip
    for col in cols:
        table.add_column(col, justify="right")
    for n in FLEETS:
        enc_one, enc_batch, dec_one, dec_gram, dec_all = bench_batch(n, count)
        table.add_row(
            f"{n:,}", f"{enc_one:,.0f}", f"{enc_batch:,.0f}", f"{enc_batch / enc_one:.1f}x",
            f"{dec_one:,.0f}", f"{dec_gram:,.0f}", f"{dec_gram / dec_one:.1f}x",
            f"{dec_all:,.0f}", f"{dec_all / dec_one:.1f}x",
        )  # fmt: skip
    return table


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--count", type=int, default=50_000, help="messages per measurement (default 50000)")
    count = parser.parse_args().count

    table = Table(title=f"MAVLink 2 throughput, {count} messages each (msg/s)")
    for col in ("message", "encode", "parse", "memory pair", "UDP loopback", "UDP lost"):
        table.add_column(col, justify="right" if col != "message" else "left")
    for name, make in (("AMUSSEL_STATUS", amussel_status), ("GLOBAL_POSITION_INT", global_position_int)):
        a, b = memory_pair()
        mem, _ = bench_link(make, count, a, b)
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
            probe.bind(("127.0.0.1", 0))
            port = probe.getsockname()[1]
        server = open_transport(f"udp:127.0.0.1:{port}", listen=True)
        client = open_transport(f"udp:127.0.0.1:{port}")
        try:
            udp, lost = bench_link(make, count, client, server)
        finally:
            client.close()
            server.close()
        table.add_row(
            name, f"{bench_encode(make, count):,.0f}", f"{bench_parse(make, count):,.0f}",
            f"{mem:,.0f}", f"{udp:,.0f}", str(lost),
        )
    console = Console(width=130)
    console.print(table)
    console.print(batch_table(count))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
