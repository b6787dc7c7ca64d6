"""`vil modem`: a nanomodem v3 emulated on a pseudo-terminal (or a serial device), over the channel model.

    vil modem --nodes 5@300,0,5 9@2400,0,5       # units 5 and 9 at 300 m and 2.4 km east, 5 m deep
    vil modem --scenario pool12-acoustic         # the scenario's aMussels at their start, this unit at the aPad's home
    vil modem --device /dev/ttyUSB1 --nodes 5@100,0,2
    vil modem --scenario pool12-acoustic --sea udp:127.0.0.1:14660   # its aMussels simulated by a GCS:
    vil gcs --sitl --scenario missions/pool12-acoustic.toml --modem /dev/pts/N --sea udp:127.0.0.1:14660

The first line printed is the serial device it serves (a new pty: /dev/pts/N); open it at 9600 8N1
and speak the unit's protocol (its user guide v3.2): `$Axxx` set the address, `$?` status with the
supply voltage, `$Pxxx` ping (`$Pxxx`, then `#RxxxTyyyyy`, range = y x c x 3.125e-5 m, or `#TO`
after 4 s), `$Vxxx` a remote unit's voltage, `$Bnn<data>` broadcast, `$Uxxxnn<data>` unicast,
`$Mxxxnn<data>` unicast with acknowledgement, `$Txxx` test message, `$Exxxnn<data>` echo, `$Q`
quality of the last packet. Acknowledgements start with `$`, results with `#`, both end CR LF; an
unknown or invalid command, or a gap of more than --gap (2 ms) between a command's bytes, answers `E`.

The other units are simulated on the channel model (acoustic/, docs/acoustic.md): they hear what
this one sends with the propagation delay, loss, half duplex and collisions of the channel, and
answer pings, acknowledged unicasts, voltage requests and echoes. --nodes gives them as
ADDRESS@X,Y,Z (metres east, north and down from this unit; :VOLTS for a supply other than 12 V);
--scenario gives its [acoustic] parameters, its aMussels (address = id, at their start positions on
the seabed) and puts this unit at the first aPad's home. Same --seed, same bytes in at the same
times: the same answers. Ctrl-C ends it, with what happened counted on stderr.
"""

from __future__ import annotations

import argparse
import re
import sys

import numpy as np

from acoustic.airtime import PING_TIMEOUT_S
from acoustic.nanomodem.emulator import ModemEmulator, RemoteUnit
from acoustic.nanomodem.host_commands import GAP_S, MAX_ADDRESS
from acoustic.nanomodem.sea import parse_udp
from acoustic.params import AcousticParams
from missiontime.durations import parse_duration_s

_NODE = re.compile(r"^(\d{1,3})@(-?[\d.]+),(-?[\d.]+),(-?[\d.]+)(?::([\d.]+))?$")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--device", metavar="DEV", help="serve this serial device (a path or pyserial URL) "
                        "instead of a new pseudo-terminal")
    parser.add_argument("--nodes", metavar="A@X,Y,Z", nargs="+", default=[],
                        help="remote units: address @ metres east,north,down from this unit (:VOLTS optional)")
    parser.add_argument("--scenario", metavar="FILE", help="its [acoustic] table, its aMussels as remote units, "
                        "this unit at its first aPad's home (a file, or a name in missions/)")
    parser.add_argument("--sea", metavar="udp:HOST:PORT", help="also listen here for simulated remote units "
                        "(a GCS's simulated aMussels: `vil gcs --modem DEV --sea udp:HOST:PORT`): they send in "
                        "the channel and hear what reaches them (acoustic/nanomodem/sea.py)")
    parser.add_argument("--address", type=int, default=0, help="this unit's address at start (0-255; $A changes it)")
    parser.add_argument("--supply", type=float, default=12.0, metavar="VOLTS", help="this unit's supply ($?)")
    parser.add_argument("--seed", type=int, default=None, help="the channel's seed (default: the scenario's, or 1)")
    parser.add_argument("--ping-timeout", default=f"{PING_TIMEOUT_S:g}s", metavar="DURATION",
                        help="how long a ping or $M/$V waits before #TO (the unit's: 4s)")
    parser.add_argument("--gap", default=f"{GAP_S * 1000:g}ms", metavar="DURATION",
                        help="the longest gap between a command's bytes before E (the unit's: about 2ms)")


def parse_nodes(specs: list[str]) -> tuple[RemoteUnit, ...]:
    """`ADDRESS@X,Y,Z[:VOLTS]` each; ValueError (one line) for a bad one."""
    units = []
    for spec in specs:
        m = _NODE.match(spec.strip())
        if m is None or int(m[1]) > MAX_ADDRESS:
            raise ValueError(f"--nodes: {spec!r} is not ADDRESS@X,Y,Z[:VOLTS] (address 0-{MAX_ADDRESS}, metres)")
        units.append(RemoteUnit(int(m[1]), (float(m[2]), float(m[3]), float(m[4])),
                                float(m[5]) if m[5] else 12.0))
    return tuple(units)


def scenario_units(name: str) -> tuple[AcousticParams, tuple[float, float, float], tuple[RemoteUnit, ...], int]:
    """A scenario's channel, this unit's position (the first aPad's home), its aMussels as units, its seed."""
    from gcs.scenario.model_params import fleet_params, start_config
    from gcs.scenario.reader import load_scenario
    from mussel_sim.placement import load_area

    scenario = load_scenario(name)
    area = load_area(scenario.fleet.area)
    config, frame = start_config(scenario, area, np.random.default_rng(scenario.seed))
    ids = [int(i) for i in config.ids]
    if max(ids, default=0) > MAX_ADDRESS:
        raise ValueError(f"{scenario.path}: aMussel ids above {MAX_ADDRESS} have no modem address")
    x, y = frame.to_local(config.lat_deg, config.lon_deg)
    hx, hy = frame.to_local(scenario.apad.home_lat_deg, scenario.apad.home_lon_deg)
    depth = fleet_params(scenario).seabed_depth_m
    units = tuple(RemoteUnit(i, (float(px - hx), float(py - hy), depth)) for i, px, py in zip(ids, x, y, strict=True))
    return scenario.acoustic, (0.0, 0.0, 0.0), units, scenario.seed


def run(args: argparse.Namespace) -> int:
    from acoustic.nanomodem.serve import serve
    from gcs.scenario.fields import ScenarioError

    try:
        params, position, units, seed = (scenario_units(args.scenario) if args.scenario
                                         else (AcousticParams(), (0.0, 0.0, 0.0), (), 1))
        units += parse_nodes(args.nodes)
        if not 0 <= args.address <= MAX_ADDRESS:
            raise ValueError(f"--address: {args.address} is outside 0..{MAX_ADDRESS}")
        if args.address in [u.address for u in units]:  # a remote unit would answer what is addressed to this one
            raise ValueError(f"--address: {args.address:03d} is also a remote unit's address")
        sea = parse_udp(args.sea) if args.sea else None
        core = ModemEmulator(params, units, np.random.default_rng(seed if args.seed is None else args.seed),
                             address=args.address, position_m=position, supply_v=args.supply,
                             gap_s=parse_duration_s(args.gap), ping_timeout_s=parse_duration_s(args.ping_timeout))
    except (ValueError, ScenarioError, OSError) as exc:  # OSError: a device or file that cannot be read
        print(f"vil modem: {exc}", file=sys.stderr)
        return 2
    where = ", ".join(f"{u.address:03d} at {np.hypot(*u.position_m[:2]):.0f} m" for u in units) or "none"
    try:
        return serve(core, args.device, sys.stdout,
                     describe=f"vil modem: nanomodem v3, address {args.address:03d}; remote units: {where}"
                     + (f"; their sea at udp:{sea[0]}:{sea[1]}" if sea else ""), sea=sea)
    except OSError as exc:
        print(f"vil modem: {args.device or 'pty'}: {exc}", file=sys.stderr)
        return 1
