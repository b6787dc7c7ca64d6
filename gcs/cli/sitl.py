"""`vil sitl`: the SITL aPad alone, in real time, on UDP, TCP or serial; with --scenario, the scenario's aPads.

    vil sitl                                     # listen on udp:127.0.0.1:14550, at pool12's home
    vil sitl --scenario pool12                   # pool12's aPad: its home, parameters, geofence, current
    vil sitl --scenario pool12x2                 # its two aPads on udp ports 14550, 14551, each from its [[apad]]
    vil sitl --connect udp:127.0.0.1:14550       # send to a listening GCS (mavproxy --master=udpin:...)
    vil sitl --listen tcp:0.0.0.0:5760 --home 45.43,12.33 --current 0.1,0 --log-dir runs/sitl
    vil sitl --count 3                           # aPads 1, 2, 3 on udp ports 14550, 14551, 14552, 5 m apart

With --scenario (a file, or a name in missions/) each aPad is one of the scenario's [apad] tables:
its system id, home and parameters (speed, Go To radius, dock reach and times), the geofence the
scenario's missions use (its water area grown by a few metres) and its water current; --count N
serves the first N of them, --param, --current and --geofence override the scenario's. Without
--home or --scenario the aPad starts at pool12's home (the scenario `vil gcs` opens by default)
and says so. Durations take their unit: --duration 90s, 40min, 1h.

The aPad itself is `apad_sitl.serve` (also `python -m apad_sitl`, without --scenario): this module
only reads the scenario, which the aPad's package never imports.
"""

from __future__ import annotations

import argparse
import sys

from apad_sitl import serve
from gcs.scenario.reader import Scenario, ScenarioError, load_scenario


def add_arguments(parser: argparse.ArgumentParser) -> None:
    serve.add_arguments(parser)
    parser.add_argument("--scenario", metavar="FILE",
                        help="serve the scenario's aPads (a file, or a name in missions/: pool12, pool12x2, ...)")


def run(args: argparse.Namespace) -> int:
    if args.scenario is None:
        return serve.run(args)
    try:
        scenario = load_scenario(args.scenario)
        apads, fence = scenario_apads(scenario, args)
    except ScenarioError as exc:
        print(f"vil sitl: {exc}", file=sys.stderr)
        return 2
    env = scenario.environment
    n, given = len(apads), len(scenario.apads)
    which = ("its aPad" if given == 1 else f"its {n} aPads" if n == given
             else f"the first {'' if n == 1 else f'{n} '}of its {given} aPads")
    print(f"vil sitl: {scenario.name} ({scenario.path}): {which} at {'its home' if n == 1 else 'their homes'} "
          "with the scenario's parameters" + ("" if args.geofence else ", its water area as the geofence"), flush=True)
    return serve.serve(args, apads, args.current or (env.current_east_mps, env.current_north_mps), fence)


def scenario_apads(scenario: Scenario, args: argparse.Namespace
                   ) -> tuple[list[serve.ApadSpec], list[tuple[float, float]]]:
    """The aPads to serve (the scenario's first --count, default all) and the geofence ring the
    scenario's missions give them; `ScenarioError` (one line) for flags that contradict it."""
    from gcs.mission.world import GEOFENCE_BUFFER_M
    from gcs.scenario.model_params import apad_params, geofence_ring
    from mussel_sim.placement import load_area

    given = len(scenario.apads)
    for flag, value in (("--home", args.home), ("--sysid", args.sysid)):
        if value is not None:
            raise ScenarioError(f"{flag} and --scenario both say it: the scenario's [apad] tables give each "
                                f"aPad its {flag[2:]}; leave {flag} out (or the scenario)")
    count = given if args.count is None else args.count
    if count > given:
        raise ScenarioError(f"--count {count}: {scenario.name} has {given} aPad{'s' * (given > 1)} "
                            f"({'[[apad]] tables' if given > 1 else 'one [apad] table'})")
    try:
        area = load_area(scenario.fleet.area)
    except (OSError, ValueError, KeyError, TypeError, AttributeError) as exc:
        raise ScenarioError(f"{scenario.fleet.area}: bad area: {exc}") from None
    fence = geofence_ring(area, area.frame(), GEOFENCE_BUFFER_M)
    apads = [serve.ApadSpec(a.system_id, a.home_lat_deg, a.home_lon_deg,
                            serve.with_params(apad_params(scenario, a), args), f" ({scenario.name}'s)")
             for a in scenario.apads[:count]]
    return apads, fence
