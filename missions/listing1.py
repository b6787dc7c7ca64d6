"""The paper's Listing 1, runnable: go to aMussel 24's last position, then dock it into slot 2.

    vil sitl &                                             # a SITL aPad on udp:127.0.0.1:14550
    python missions/listing1.py --connect udp:127.0.0.1:14550

As in the paper's vehicle-in-the-loop setup, the shore station simulates the aMussel: this
script publishes aMussel 24 (AMUSSEL_STATUS over MAVLink) a few metres from wherever the aPad
is, then runs the listing against the aPad. Exits 0 once aMussel 24 is docked.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from apad_sitl.vocabulary import Progress
from gcs.link.apad_api import ApadApi, CommandError
from gcs.link.router import Link
from mavlink_dialect import AddressError, Codec, open_transport
from missiontime import WallClock
from mussel_sim.comms import FLEET_COMPONENT_ID, FLEET_SYSTEM_ID, FleetRunner
from mussel_sim.fleet_state import FleetParams, state_from_arrays
from mussel_sim.geo import LocalFrame

MUSSEL_ID = 24
SLOT = 2


def simulate_mussel(link: Link, clock: WallClock, near: tuple[float, float], distance_m: float) -> None:
    """Publish one simulated aMussel `distance_m` north-east of `near` (lat, lon), resting on the seabed."""
    frame = LocalFrame(*near)
    offset = distance_m / np.sqrt(2.0)
    params = FleetParams(drift_half_width_m=0.0)
    state = state_from_arrays([MUSSEL_ID], [offset], [offset], [0.5], params, clock.now_us)
    port = link.attach(None)
    fleet = FleetRunner(state, params, np.random.default_rng(24), frame, Codec(FLEET_SYSTEM_ID, FLEET_COMPONENT_ID),
                        port.send_bytes, local=port.send_local,
                        local_batch=port.send_batch)
    port.handler = fleet.handle
    fleet.register(clock.scheduler, clock.now_us)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--connect", default="udp:127.0.0.1:14550", help="the aPad (default udp:127.0.0.1:14550)")
    parser.add_argument("--distance", type=float, default=10.0, help="how far from the aPad aMussel 24 rests [m]")
    parser.add_argument("--timeout", type=float, default=300.0, help="give up after this many seconds")
    parser.add_argument("--wait", type=float, default=10.0, help="how long to wait for the aPad's heartbeat [s]")
    args = parser.parse_args(argv)

    clock = WallClock()
    link = Link(clock)
    try:
        link.add_transport(open_transport(args.connect))
    except AddressError as exc:
        print(f"listing1: {exc}", file=sys.stderr)
        return 2
    api = ApadApi(link, clock)
    try:
        id_self = api.wait_apad(timeout_s=args.wait)
    except TimeoutError as exc:
        print(f"listing1: {exc} (is `vil sitl` running on {args.connect}?)", file=sys.stderr)
        return 1
    simulate_mussel(link, clock, api.position(id_self), args.distance)
    clock.sleep(1.5)  # let aMussel 24's status reach the aPad and us

    # --- the paper's Listing 1 ------------------------------------------------------------
    lat = api.get_location(MUSSEL_ID).lat
    lon = api.get_location(MUSSEL_ID).lon
    api.go_to([lat, lon])
    while api.goto_status(id_self) == Progress.IN_PROGRESS:
        print("GoTo in progress.")
        clock.sleep(1)
        if clock.time() > args.timeout:
            print("listing1: timed out", file=sys.stderr)
            return 1
    print("Goal reached. Docking start.")
    try:
        api.docking(True, SLOT, MUSSEL_ID)
    except CommandError as exc:  # refused (e.g. slot 2 still holds aMussel 24 from a run before) or unanswered
        print(f"listing1: {exc.words} ({exc})", file=sys.stderr)
        link.close()
        return 1
    # ----------------------------------------------------------------------------------------

    while api.docking_status(id_self) == Progress.IN_PROGRESS:
        clock.sleep(1)
    slot = api.slots(id_self)[SLOT - 1]
    docked = api.docking_status(id_self) == Progress.DONE and slot.mussel_id == MUSSEL_ID
    print(f"Docking {'done' if docked else 'failed'}: slot {SLOT} holds aMussel {slot.mussel_id or 'none'}"
          f" ({slot.latch.name}{', charging' if slot.charging else ''}).")
    link.close()
    return 0 if docked else 1


if __name__ == "__main__":
    sys.exit(main())
