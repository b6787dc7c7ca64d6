"""A mission with several aPads: one energy-sharing loop per aPad, on one clock, sharing one fleet.

Each loop is the paper's loop on its aPad's share of the fleet (`gcs.mission.swarm`), run as a
process of `missiontime.processes` so that all of them wait on the one clock in turn, in lockstep
as deterministic as a single aPad, and in the field on the wall clock. The watch re-shares the
fleet when an aPad is lost or comes back.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from gcs.mission.control import EndReason, Phase
from gcs.mission.loop import EnergySharingLoop, LoopControl
from gcs.mission.swarm import FleetShares, SwarmWatch
from gcs.mission.world import World
from missiontime import Clock, seconds_to_us
from missiontime.processes import Processes

APAD_WAIT_S = 10.0


@dataclass
class SwarmOutcome:
    loops: dict[int, EnergySharingLoop]  # by aPad system id
    shares: FleetShares
    watch: SwarmWatch

    @property
    def cost_m(self) -> float:
        return sum(loop.status.cost_m for loop in self.loops.values())

    @property
    def cycles(self) -> int:
        return sum(loop.status.cycles for loop in self.loops.values())

    @property
    def end_reason(self) -> str:
        reasons = sorted({str(loop.status.end_reason) for loop in self.loops.values()})
        return reasons[0] if len(reasons) == 1 else ", ".join(reasons)


def run_swarm(world: World, on_start: Callable[[], None] | None = None) -> SwarmOutcome:
    """Wait for every aPad, share the fleet, run every aPad's loop to the mission's end."""
    for a in world.scenario.apads:
        world.api.wait_apad(timeout_s=APAD_WAIT_S, apad_id=a.system_id)
        world.request_telemetry(apad_id=a.system_id)
    shares, watch = share_fleet(world)
    if on_start is not None:
        on_start()
    return SwarmOutcome(run_loops(world, shares, watch), shares, watch)


def share_fleet(world: World) -> tuple[FleetShares, SwarmWatch]:
    """The first sharing of the fleet among every aPad heard, and the watch that re-shares it."""
    s = world.scenario
    shares = FleetShares()
    watch = SwarmWatch(world.link.registry, shares, world.frame, {a.system_id: a.battery_end_v for a in s.apads},
                       world.events, world.clock, seed=s.seed)
    watch.check(world.clock.now_us)
    watch.register(world.clock.now_us + seconds_to_us(1.0))
    return shares, watch


def run_loops(
    world: World, shares: FleetShares, watch: SwarmWatch, controls: Mapping[int, LoopControl] | None = None,
    loops: dict[int, EnergySharingLoop] | None = None,
) -> dict[int, EnergySharingLoop]:
    """Every aPad's loop as a process on the world's clock, until all have ended. `controls`: each
    aPad's own (the console's pause, stop and commands); `loops` is filled as each loop starts."""
    loops = {} if loops is None else loops
    processes = Processes(world.clock)
    for a in world.scenario.apads:
        def script(clock: Clock, sysid: int = a.system_id) -> Any:
            control = controls.get(sysid) if controls is not None else None
            loop = loops[sysid] = world.mission_loop(control, apad_id=sysid, shares=shares, clock=clock)
            end = loop.run()
            if end == EndReason.APAD_BATTERY:  # out for good: its share goes to the others now
                watch.retire(sysid)
            return end

        processes.spawn(f"apad{a.system_id}", script)
    processes.run()
    return loops


def apad_rows(world: World, outcome: SwarmOutcome | None, single: EnergySharingLoop | None) -> list[dict[str, Any]]:
    """One row per aPad for result.json: its share, travel, dockings and how its time was spent."""
    loops = outcome.loops if outcome is not None else ({single.apad_id: single} if single is not None else {})
    rows = []
    duration_s = world.scenario.mission.duration_s
    for sysid, loop in sorted(loops.items()):
        vehicle = world.vehicles.get(sysid)
        spent = loop.status.phase_s
        first = outcome.shares.first if outcome is not None else None
        last = outcome.shares.partition if outcome is not None else None
        rows.append({
            "sysid": sysid,
            "mussels": first.shares.get(sysid, []) if first is not None else sorted(world.homes),  # its share at start
            "share_at_end": last.shares.get(sysid, []) if last is not None else sorted(world.homes),
            "travelled_m": round(vehicle.state.distance_travelled_m, 3) if vehicle is not None else None,
            "cost_m": round(loop.status.cost_m, 3),
            "dockings": len(loop.status.dockings),
            "cycles": loop.status.cycles,
            "idle_share": round(spent.get(Phase.IDLE_WAIT, 0.0) / duration_s, 4),
            "phase_s": {str(p): round(t, 1) for p, t in spent.items()},
            "end_reason": str(loop.status.end_reason),
        })
    return rows
