"""Stand-in for real aMussels in the water, as its own process: what a bridge at sea would relay.

Reports each aMussel's status (AMUSSEL_STATUS, simulated = 0) every --period seconds of wall time
to the GCS's bridge address, and obeys AMUSSEL_COMMAND: SURFACE (floating after --surface-s),
SINK (active again). Prints each command it obeys and each kind of message it hears, one line
each, for the test to read.

    python tests/sitl/real_mussel_agent.py --gcs 127.0.0.1:14600 --mussel 101:43.94002,15.43990 ...
"""

from __future__ import annotations

import argparse
import socket
import sys
import time

from mavlink_dialect import Codec, mavlink
from mussel_sim.vocabulary import MusselCommand, MusselState


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--gcs", required=True, help="HOST:PORT of the GCS's bridge")
    ap.add_argument("--mussel", action="append", required=True, metavar="ID:LAT,LON")
    ap.add_argument("--battery", type=float, default=0.3)
    ap.add_argument("--period", type=float, default=0.3)
    ap.add_argument("--surface-s", type=float, default=0.5)
    ap.add_argument("--duration", type=float, default=60.0)
    ap.add_argument("--sysid", type=int, default=60)
    args = ap.parse_args()
    host, port = args.gcs.rsplit(":", 1)
    gcs = (host, int(port))
    mussels: dict[int, tuple[int, int]] = {}
    for spec in args.mussel:
        ident, where = spec.split(":")
        lat, lon = (float(v) for v in where.split(","))
        mussels[int(ident)] = (round(lat * 1e7), round(lon * 1e7))
    state = dict.fromkeys(mussels, MusselState.ACTIVE)
    floats_at: dict[int, float] = {}
    seen: set[str] = set()  # message types heard from the GCS, printed once each
    codec = Codec(args.sysid, 1)
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", 0))
    sock.settimeout(0.05)
    start = time.monotonic()
    next_report = start
    while time.monotonic() - start < args.duration:
        now = time.monotonic()
        for m, t in list(floats_at.items()):
            if now >= t:
                state[m] = MusselState.FLOATING
                del floats_at[m]
        if now >= next_report:
            next_report = now + args.period
            for m, (lat, lon) in mussels.items():
                sock.sendto(codec.encode(mavlink.MAVLink_amussel_status_message(
                    int((now - start) * 1e6), m, lat, lon, 0.0 if state[m] != MusselState.ACTIVE else 2.0,
                    args.battery, 3600, int(state[m]), 0)), gcs)
        try:
            data = sock.recv(65535)
        except TimeoutError:
            continue
        for msg in codec.decode(data):
            if msg.get_type() not in seen:
                seen.add(msg.get_type())
                print(f"HEARD {msg.get_type()}", flush=True)
            if msg.get_type() != "AMUSSEL_COMMAND" or msg.mussel_id not in mussels:
                continue
            if msg.command == MusselCommand.SURFACE and state[msg.mussel_id] == MusselState.ACTIVE:
                state[msg.mussel_id] = MusselState.SURFACING
                floats_at[msg.mussel_id] = time.monotonic() + args.surface_s
                print(f"SURFACE {msg.mussel_id}", flush=True)
            elif msg.command == MusselCommand.SINK:
                state[msg.mussel_id] = MusselState.ACTIVE
                floats_at.pop(msg.mussel_id, None)
                print(f"SINK {msg.mussel_id}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
