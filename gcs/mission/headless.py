"""Headless mission runs: one scenario in lockstep, a `RunResult` and an output folder out.

The output folder holds the GCS .tlog, the aPad's own logs, the event log, `result.json` and
`traces.npz` (active count and battery traces per step, for reports; where the time went:
`gcs.mission.time_accounting`).
"""

from __future__ import annotations

import json
import time
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from gcs.mission.accounting import account
from gcs.mission.loop import EnergySharingLoop
from gcs.mission.results import MusselResult, RunResult
from gcs.mission.scenario import Scenario
from gcs.mission.swarm_run import apad_rows, run_swarm
from gcs.mission.time_accounting import ApadTimes, apad_shares, mussel_times, trace_arrays, track
from gcs.mission.world import LOCKSTEP_EPOCH_US, LinkOptions, World, lockstep_world
from gcs.records import checkpoint
from mavlink_dialect.transport import UdpTransport
from missiontime import seconds_to_us, us_to_s

ProgressFn = Callable[[float], None]  # receives mission time done, seconds
WorldFn = Callable[[World], None]  # reads the world when the mission has ended (`vil sweep`: the active counts)


def run_stem(scenario: Scenario) -> str:
    """What a run's folder is named after; `gcs.records.rundirs` adds -runK so runs never share one."""
    return f"{scenario.name}-{scenario.mission.collect_strategy}-seed{scenario.seed}"


def run_mission(
    scenario: Scenario, out_dir: Path | None = None, progress: ProgressFn | None = None,
    options: LinkOptions | None = None,
    resume: bool = False, on_end: WorldFn | None = None,
) -> RunResult:
    """Run one mission in lockstep to its end; write its folder if `out_dir` is given.

    `options` route the aPad link through a fault proxy over UDP and/or sign it. With `out_dir` the
    run checkpoints itself there; `resume` continues from that checkpoint (after a crash).
    """
    wall_start = time.perf_counter()
    if len(scenario.apads) > 1:
        if resume:
            raise checkpoint.CheckpointError("resuming a mission of several aPads is not supported yet")
        return _run_swarm(scenario, out_dir, progress, options, wall_start, on_end)
    ckpt_files = checkpoint.CheckpointFiles(out_dir / checkpoint.CHECKPOINT_NAME) if out_dir is not None else None
    saved = None
    if resume:
        if ckpt_files is None:
            raise checkpoint.CheckpointError("resuming needs the run's output folder")
        saved = checkpoint.load(ckpt_files)
        assert out_dir is not None
        checkpoint.cut_logs(out_dir, saved, LOCKSTEP_EPOCH_US)  # the stretch after it is simulated again
    world = lockstep_world(scenario, out_dir, options, start_us=saved.time_us if saved else 0,
                           append_logs=saved is not None)
    if out_dir is not None:
        _write_endpoints(world, out_dir)
    try:
        if saved is not None:
            checkpoint.restore(world, saved)
        if progress is not None:
            world.clock.scheduler.every(10.0, lambda now_us: progress(us_to_s(now_us)), "progress", world.clock.now_us)
        sysid = scenario.apad.system_id
        apad_times = {sysid: saved.loop_status.apad_time_us if saved is not None else {}}
        track(world, apad_times)
        world.api.wait_apad(timeout_s=10.0)
        world.request_telemetry()
        loop = world.mission_loop()
        if saved is not None:
            loop.status = saved.loop_status
        loop.status.apad_time_us = apad_times[sysid]  # the same dict: a checkpoint of the status holds it
        if ckpt_files is not None:
            files = ckpt_files
            world.clock.scheduler.every(
                checkpoint.CHECKPOINT_PERIOD_S, lambda now_us: checkpoint.save(files, checkpoint.capture(world, loop)),
                "checkpoint", world.clock.now_us + seconds_to_us(checkpoint.CHECKPOINT_PERIOD_S),
            )
        end = loop.run(resume=saved is not None)
        if on_end is not None:
            on_end(world)
        result = _result(world, loop.status.cost_m, loop.status.cycles, str(end), time.perf_counter() - wall_start,
                         out_dir, {loop.apad_id: loop}, apad_rows(world, None, loop), apad_times)
        if out_dir is not None:
            _write_outputs(world, result, out_dir, apad_times)
        if ckpt_files is not None:
            ckpt_files.remove()  # finished: nothing to resume
        return result
    finally:
        if ckpt_files is not None:
            ckpt_files.close()
        world.close()


def _run_swarm(
    scenario: Scenario, out_dir: Path | None, progress: ProgressFn | None, options: LinkOptions | None,
    wall_start: float, on_end: WorldFn | None = None,
) -> RunResult:
    """Several aPads (`gcs.mission.swarm_run`); no checkpoints yet."""
    world = lockstep_world(scenario, out_dir, options)
    try:
        if progress is not None:
            world.clock.scheduler.every(10.0, lambda now_us: progress(us_to_s(now_us)), "progress", world.clock.now_us)
        apad_times: dict[int, ApadTimes] = {a.system_id: {} for a in scenario.apads}
        track(world, apad_times)
        outcome = run_swarm(world)
        if on_end is not None:
            on_end(world)
        result = _result(world, outcome.cost_m, outcome.cycles, outcome.end_reason, time.perf_counter() - wall_start,
                         out_dir, outcome.loops, apad_rows(world, outcome, None), apad_times)
        if out_dir is not None:
            _write_outputs(world, result, out_dir, apad_times)
        return result
    finally:
        world.close()


def _result(
    world: World, cost_m: float, cycles: int, end: str, wall_s: float, out_dir: Path | None,
    loops: dict[int, EnergySharingLoop], apads: list[dict[str, Any]], apad_times: dict[int, ApadTimes],
) -> RunResult:
    s = world.scenario
    rec = world.fleet.recorder
    summary = rec.summary()
    uptime = rec.uptime_pct()
    start_battery = dict(zip(world.start.ids.tolist(), world.start.battery_frac.tolist(), strict=True))
    dockings: dict[int, list[dict[str, Any]]] = {}
    for sysid, loop in sorted(loops.items()):
        for t_s, mussel_id in loop.status.dockings:
            dockings.setdefault(mussel_id, []).append({"t_s": round(t_s, 2), "apad": sysid})
    state_s, first_depleted_s = mussel_times(rec)
    mussels = [
        MusselResult(int(i), round(start_battery[int(i)], 6), round(float(u), 4),
                     sorted(dockings.get(int(i), []), key=lambda d: d["t_s"]), states, first)
        for i, u, states, first in zip(rec.ids, uptime, state_s, first_depleted_s, strict=True)
    ]
    apads = [row | apad_shares(apad_times.get(row["sysid"], {})) for row in apads]
    travelled = sum(v.state.distance_travelled_m for v in world.vehicles.values())
    stats = world.link.codec.stats
    homes = {m: (h.lat, h.lon) for m, h in world.homes.items()}
    whereabouts = [
        {"id": a.mussel_id, "where": a.where, "detail": a.detail}
        for a in account(world.fleet.state, world.frame, homes, world.link.vehicles, world.fleet.params.seabed_depth_m)
    ]
    vehicles = list(world.vehicles.values())  # the aPads' counters are summed over the swarm
    messages = {"gcs_sent": stats.sent, "fleet_sent": world.fleet.codec.stats.sent,
                "apad_sent": sum(v.codec.stats.sent for v in vehicles),
                "gcs_bad_data": world.link.bad_data,
                "apad_bad_data": sum(v.codec.stats.bad_data for v in vehicles)}
    # What each side refused after decoding, by reason (validation, id clashes, handler errors).
    messages |= {f"gcs_dropped.{reason}": n for reason, n in sorted(world.link.dropped.items())}
    messages |= {f"fleet_dropped.{reason}": n for reason, n in sorted(world.fleet.dropped.items())}
    apad_dropped: Counter[str] = sum((Counter(v.dropped) for v in vehicles), Counter())
    messages |= {f"apad_dropped.{reason}": n for reason, n in sorted(apad_dropped.items())}
    proxied: Counter[str] = Counter()
    for proxy in world.proxies:
        for way, st in (("to_apad", proxy.stats[True]), ("to_gcs", proxy.stats[False])):
            proxied.update({f"proxy_{way}_{k}": v for k, v in vars(st).items()})
    messages |= dict(proxied)
    return RunResult(
        scenario=s.name,
        strategy=s.mission.collect_strategy,
        seed=s.seed,
        theta=s.mission.theta,
        duration_s=s.mission.duration_s,
        uptime={"avg": round(summary.avg_uptime_pct, 4), "max": round(summary.max_uptime_pct, 4),
                "min": round(summary.min_uptime_pct, 4)},
        cost_m=round(cost_m, 3),
        active_avg=round(summary.avg_active, 4),
        wall_s=round(wall_s, 3),
        mussels=mussels,
        travelled_m=round(travelled, 3),
        cycles=cycles,
        end_reason=end,
        out_dir=str(out_dir) if out_dir is not None else "",
        messages=messages,
        whereabouts=whereabouts,
        apads=apads,
    )


def _write_endpoints(world: World, out_dir: Path) -> None:
    """endpoints.json: the UDP ports a run over real sockets opened (ephemeral, so unknowable from
    outside otherwise): each aPad's, its fault proxy's and the GCS link's. Tests spray them."""
    apads = {str(s): v.transport for s, v in world.vehicles.items()}
    ports: dict[str, Any] = {
        "apad": {s: t.local_port for s, t in apads.items() if isinstance(t, UdpTransport)},
        "proxy": [p.listen_port for p in world.proxies],
        "gcs": [t.local_port for t in (p.transport for p in world.link._pollers) if isinstance(t, UdpTransport)],
    }
    (out_dir / "endpoints.json").write_text(json.dumps(ports) + "\n")


def _write_outputs(world: World, result: RunResult, out_dir: Path, apad_times: dict[int, ApadTimes]) -> None:
    rec = world.fleet.recorder
    steps, battery = rec.battery_trace()
    arrays: dict[str, Any] = dict(
        ids=rec.ids, step_time_us=rec.step_time_us(), active_count=rec.active_count(),
        battery_steps=steps, battery=battery, trace_ids=rec.trace_ids, **trace_arrays(rec, apad_times),
    )
    np.savez_compressed(out_dir / "traces.npz", **arrays)
    (out_dir / "result.json").write_text(json.dumps(result.to_json(), indent=1) + "\n")
