"""MAVLink throughput: messages per second encoded and parsed, over the in-memory pair and real UDP.

Two messages: the dialect's AMUSSEL_STATUS (the fleet's bulk traffic) and common's
GLOBAL_POSITION_INT (the aPad's). Over UDP every message is its own datagram, sent in bursts
small enough for the loopback socket buffer, so the figure is the whole send/recv/parse path.

    .venv/bin/python bench/mavlink_throughput.py [--count N]
"""

from __future__ import annotations

import argparse
import socket
import time
from collections.abc import Callable

from rich.console import Console
from rich.table import Table

from mavlink_dialect import Codec, mavlink, memory_pair, open_transport
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
    Console(width=120).print(table)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
