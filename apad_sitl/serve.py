"""`vil sitl` / `python -m apad_sitl`: the SITL aPad alone, in real time, on UDP, TCP or serial.

    vil sitl                                     # listen on udp:127.0.0.1:14550
    vil sitl --connect udp:127.0.0.1:14550       # send to a listening GCS (mavproxy --master=udpin:...)
    vil sitl --listen tcp:0.0.0.0:5760 --home 45.43,12.33 --current 0.1,0 --log-dir runs/sitl
    vil sitl --count 3                           # aPads 1, 2, 3 on udp ports 14550, 14551, 14552, 5 m apart

Without --home the aPad starts at pool12's home (the scenario `vil gcs` opens by default) and says
so. Durations take their unit: --duration 90s, 40min, 1h. `vil sitl --scenario` (gcs.cli.sitl)
serves a scenario's aPads through `serve`.

This is the edge: it opens the transport, reads the wall clock and handles Ctrl-C; the vehicle
itself stays clock-free. With signing on and a log folder, it also keeps the signing timestamps
there across restarts (`mavlink_dialect.signing_state`), so frames recorded before a restart are
refused after it; a damaged file is reported in one line and the aPad starts refusing the past.
"""

from __future__ import annotations

import argparse
import signal
import sys
import time
from dataclasses import dataclass, replace
from pathlib import Path
from types import FrameType
from typing import Any

from apad_sitl.endpoint import SitlVehicle
from apad_sitl.params import ApadParams, ParamError, with_param
from mavlink_dialect import AddressError, Transport, mavlink, open_transport, signing
from mavlink_dialect.signing import SigningKeyError, load_key
from mavlink_dialect.signing_state import SAVE_PERIOD_S, SigningKeeper
from missiontime import Scheduler, WallClock
from missiontime.durations import MAX_MISSION_S, parse_duration_s
from mussel_sim.geo import LocalFrame

DEFAULT_LISTEN = "udp:127.0.0.1:14550"
DEFAULT_HOME = (43.9400000, 15.4398381)  # pool12's (missions/pool12.toml; a test keeps them equal)
DEFAULT_HOME_NOTE = " (the default, pool12's: --home LAT,LON or --scenario NAME to choose)"
# Stock consoles draw their HUD from these; in real time the extra bytes cost nothing.
REALTIME_RATES_HZ = {mavlink.MAVLINK_MSG_ID_ATTITUDE: 4.0, mavlink.MAVLINK_MSG_ID_VFR_HUD: 2.0}


def _pair(text: str, what: str) -> tuple[float, float]:
    parts = text.split(",")
    try:
        a, b = (float(p) for p in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{what} must be two numbers A,B, got {text!r}") from None
    return a, b


def _home(text: str) -> tuple[float, float]:
    lat, lon = _pair(text, "--home")
    if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
        raise argparse.ArgumentTypeError(f"--home {text!r}: latitude must be in [-90, 90], longitude in [-180, 180]")
    return lat, lon


def _current(text: str) -> tuple[float, float]:
    east, north = _pair(text, "--current")
    if not (abs(east) <= 5.0 and abs(north) <= 5.0):
        raise argparse.ArgumentTypeError(f"--current {text!r}: more than 5 m/s is not a sea we work in")
    return east, north


MAX_COUNT = 16
COUNT_SPACING_M = 5.0


def _count(text: str) -> int:
    if not text.isdigit() or not 1 <= int(text) <= MAX_COUNT:
        raise argparse.ArgumentTypeError(f"--count must be 1..{MAX_COUNT}, got {text!r}")
    return int(text)


def _nth_address(address: str, k: int) -> str:
    """The k-th aPad's address: the same host, the port k above (serial has no ports: refused)."""
    if k == 0:
        return address
    scheme, _, rest = address.partition(":")
    host, _, port = rest.rpartition(":")
    if scheme not in ("udp", "tcp") or not port.isdigit() or int(port) + k > 65535:
        raise AddressError(f"--count needs udp:HOST:PORT or tcp:HOST:PORT with room for {k + 1} ports, got {address!r}")
    return f"{scheme}:{host}:{int(port) + k}"


def _sysid(text: str) -> int:
    if not text.isdigit() or not 1 <= int(text) <= 255:
        raise argparse.ArgumentTypeError(f"--sysid must be 1..255, got {text!r}")
    return int(text)


def _duration(text: str) -> float:
    try:
        return parse_duration_s(text, MAX_MISSION_S)  # longer: leave --duration out and stop it with Ctrl-C
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def _param(text: str) -> tuple[str, float]:
    name, sep, value = text.partition("=")
    try:
        with_param(ApadParams(), name.strip().upper(), float(value))
    except (ValueError, ParamError) as exc:
        if not sep:
            raise argparse.ArgumentTypeError(f"--param expects NAME=VALUE, got {text!r}") from None
        raise argparse.ArgumentTypeError(f"--param {text}: {exc}") from None
    return name.strip().upper(), float(value)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    link = parser.add_mutually_exclusive_group()
    link.add_argument("--listen", metavar="ADDR",
                      help=f"serve whoever talks to us: udp:HOST:PORT, tcp:HOST:PORT, serial:DEV[:BAUD] "
                           f"(default {DEFAULT_LISTEN})")
    link.add_argument("--connect", metavar="ADDR", help="send to a listening GCS at udp:HOST:PORT or tcp:HOST:PORT")
    parser.add_argument("--home", type=_home, metavar="LAT,LON",
                        help="home and start position in degrees (default: pool12's home, "
                             f"{DEFAULT_HOME[0]:.7f},{DEFAULT_HOME[1]:.7f})")
    parser.add_argument("--sysid", type=_sysid, help="MAVLink system id, 1..255 (default 1)")
    parser.add_argument("--count", type=_count, metavar="N",
                        help=f"serve N aPads (up to {MAX_COUNT}): system ids SYSID.., each on the next port "
                             f"(one link each), homes {COUNT_SPACING_M:g} m apart eastwards (default 1)")
    parser.add_argument("--current", type=_current, metavar="E,N",
                        help="water current east,north in m/s (default 0,0)")
    parser.add_argument("--param", type=_param, action="append", default=[], metavar="NAME=VALUE",
                        help="set an aPad parameter at start, e.g. SPEED_MAX=0.3 (repeatable)")
    parser.add_argument("--log-dir", metavar="DIR", help="write the aPad's .tlog and event log here")
    parser.add_argument("--duration", type=_duration, metavar="T",
                        help="stop after this long, with its unit: 90s, 40min, 1h (default: until Ctrl-C)")
    parser.add_argument("--signing-key", type=Path, metavar="FILE",
                        help="MAVLink 2 signing with the passphrase in FILE (default: $VIL_SIGNING_KEY if set); "
                             "unsigned commands are then refused")
    parser.add_argument("--geofence", type=Path, metavar="GEOJSON",
                        help="water area: Go To targets outside it and undocking outside it are refused")


def _fence(path: Path) -> list[tuple[float, float]]:
    """The outer ring of the area in a GeoJSON file (several polygons: their hull), as (lat, lon)."""
    import json

    from mussel_sim.placement import load_area

    try:
        geom = load_area(path).geometry  # finite WGS84 vertices, a valid polygon
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path}: not JSON: {exc.msg}") from None
    except (ValueError, KeyError, TypeError, AttributeError) as exc:
        raise ValueError(f"{path}: not a geofence: {exc}") from None
    if geom.geom_type == "MultiPolygon":
        geom = geom.convex_hull
    return [(float(y), float(x)) for x, y in geom.exterior.coords]


def _stop(signum: int, frame: FrameType | None) -> None:
    raise KeyboardInterrupt


@dataclass(frozen=True)
class ApadSpec:
    """One aPad to serve: its system id, home and parameters."""

    system_id: int
    home_lat_deg: float
    home_lon_deg: float
    params: ApadParams
    note: str = ""  # said after its home on the start line: where the home comes from


def with_params(params: ApadParams, args: argparse.Namespace) -> ApadParams:
    """`params` with the --param settings on top."""
    for name, value in args.param:
        params = with_param(params, name, value)
    return params


def run(args: argparse.Namespace) -> int:
    """--count aPads from --sysid, the first at --home, the others COUNT_SPACING_M apart eastwards."""
    sysid, count = args.sysid or 1, args.count or 1
    if sysid + count - 1 > 255:
        print(f"vil sitl: --sysid {sysid} --count {count} runs past system id 255", file=sys.stderr)
        return 2
    frame = LocalFrame(*(args.home or DEFAULT_HOME))
    params = with_params(ApadParams(), args)
    apads = []
    for k in range(count):
        lat, lon = (float(v) for v in frame.to_geodetic(COUNT_SPACING_M * k, 0.0))
        apads.append(ApadSpec(sysid + k, lat, lon, replace(params, sysid_thismav=sysid + k),
                              "" if args.home else DEFAULT_HOME_NOTE))
    return serve(args, apads, args.current or (0.0, 0.0))


def serve(args: argparse.Namespace, apads: list[ApadSpec], current: tuple[float, float],
          fence: list[tuple[float, float]] | None = None) -> int:
    """Serve `apads` in real time, each on its own link (the address's port + k) until --duration
    or Ctrl-C; `fence` is the geofence ring unless --geofence gives one."""
    listen = args.connect is None
    address = args.listen or args.connect or DEFAULT_LISTEN
    transports: list[Transport] = []
    try:
        for k in range(len(apads)):
            transports.append(open_transport(_nth_address(address, k), listen=listen))
    except AddressError as exc:
        for t in transports:
            t.close()
        print(f"vil sitl: {exc}", file=sys.stderr)
        return 2
    clock = WallClock(Scheduler())
    epoch_us = int(time.time() * 1e6)
    try:
        key = load_key(args.signing_key)
        fence = _fence(args.geofence) if args.geofence else fence
    except (SigningKeyError, OSError, ValueError, KeyError) as exc:
        for t in transports:
            t.close()
        print(f"vil sitl: {exc}", file=sys.stderr)
        return 2
    vehicles: list[SitlVehicle] = []
    try:
        for a, transport in zip(apads, transports, strict=True):
            vehicles.append(SitlVehicle(
                transport, a.params, a.home_lat_deg, a.home_lon_deg, system_id=a.system_id,
                current_mps=current, log_dir=args.log_dir, rates_hz=REALTIME_RATES_HZ, log_epoch_us=epoch_us,
                signing_key=key, geofence_deg=fence,
            ))
    except OSError as exc:
        for v in vehicles:
            v.close()
        for t in transports[len(vehicles):]:
            t.close()
        print(f"vil sitl: cannot write logs in {args.log_dir}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    previous: dict[int, Any] = {}
    try:
        # `kill` stops as cleanly as Ctrl-C; SIGINT too when a shell started us in the background.
        previous[signal.SIGTERM] = signal.signal(signal.SIGTERM, _stop)
        previous[signal.SIGINT] = signal.signal(signal.SIGINT, signal.default_int_handler)
    except ValueError:
        pass  # not the main thread: the embedder handles signals
    keepers = [_keep_signing_state(v, clock, epoch_us) if key is not None else None for v in vehicles]
    verb = "listening on" if listen else "connecting to"
    east, north = current
    for k, (vehicle, a) in enumerate(zip(vehicles, apads, strict=True)):
        vehicle.attach(clock.scheduler, clock.now_us)
        print(f"vil sitl: aPad sysid {vehicle.system_id} {verb} {_nth_address(address, k)}, "
              f"home {vehicle.home_lat_deg:.6f},{vehicle.home_lon_deg:.6f}{a.note}, current {east:g},{north:g} m/s"
              + (f", logs in {args.log_dir}" if args.log_dir else ""), flush=True)
    try:
        if args.duration is not None:
            clock.sleep(args.duration)
        else:
            while True:
                clock.sleep(3600.0)
    except KeyboardInterrupt:
        pass
    finally:
        for vehicle, keeper, transport in zip(vehicles, keepers, transports, strict=True):
            if keeper is not None:
                keeper.save()
            c = vehicle.codec
            vehicle.event("link", received=c.stats.received, bad_data=c.stats.bad_data, unknown=c.stats.unknown,
                          signing_refused=c.signing_refusals, transport_dropped=dict(getattr(transport, "dropped", {})),
                          signing_save_errors=keeper.save_errors if keeper is not None else 0,
                          dropped=dict(vehicle.dropped), floods_cut=clock.scheduler.drains_cut)
            vehicle.close()
        for signum, handler in previous.items():
            signal.signal(signum, handler)
    return 0


def _keep_signing_state(vehicle: SitlVehicle, clock: WallClock, epoch_us: int) -> SigningKeeper | None:
    """Restore the signing timestamps saved beside the logs and save them every SAVE_PERIOD_S."""
    if vehicle.log is None:
        print("vil sitl: signing timestamps are not kept without --log-dir: frames recorded in the minute "
              "before a restart would be accepted after it", file=sys.stderr)
        return None
    keeper = SigningKeeper(vehicle.log.signing_path, vehicle.codec.mav,
                           lambda: signing.timestamp_ticks(epoch_us, clock.now_us))
    notice = keeper.start()
    if notice is not None:
        print(f"vil sitl: {notice}", file=sys.stderr)
        vehicle.event("signing_state_damaged", notice=notice)

    def save(now_us: int) -> None:
        keeper.save()  # a refusal of the disk is counted in keeper.save_errors; the aPad sails on

    clock.scheduler.every(SAVE_PERIOD_S, save, "signing_state.save", clock.now_us)
    return keeper
