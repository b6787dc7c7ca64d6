"""What a mission leaves: its `Outcome` (the loops, the shares, each aPad's time) and, from the world at
its end, the `RunResult` (result.json) and the run folder's traces.npz and endpoints.json."""

from __future__ import annotations

import json
from collections import Counter
from dataclasses import dataclass
from typing import Any

import numpy as np

from apad_sitl.energy_counters import EnergyCounters
from gcs.loop.control import Phase
from gcs.loop.energy_sharing import EnergySharingLoop
from gcs.mission.apad_record import ApadRecord, energy_now
from gcs.mission.time_accounting import ApadTimes, apad_shares, mussel_times, trace_arrays
from gcs.mission.world import World
from gcs.records.run_folder import RunFolder
from gcs.results.accounting import account
from gcs.results.days import day_rows
from gcs.results.run_result import MusselResult, RunResult
from gcs.swarm.shares import FleetShares
from mavlink_dialect.transport import UdpTransport

TRACES_FORMAT = 2  # traces.npz with state traces, aPad tracks and positions (1: none of them, no field)


@dataclass
class Outcome:
    """A mission's loops (by aPad system id), who served whom (several aPads), each aPad's time."""

    loops: dict[int, EnergySharingLoop]
    shares: FleetShares | None
    apad_times: dict[int, ApadTimes]
    apad_record: ApadRecord | None = None

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


def collect_result(world: World, outcome: Outcome, wall_s: float) -> RunResult:
    """The run's figures (the paper's Table II and where the time went), from the world at its end."""
    loops, apad_times = outcome.loops, outcome.apad_times
    world.fleet.bring_up_to(world.clock.now_us)  # the event platform steps it only where it changes: now (to its end)
    apads = apad_rows(world, outcome)
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
    taken, due = rec.samples()
    fleet = world.fleet.state  # its ids are the recorder's: its behaviour profiles (at the end) go beside
    names = [p.name for p in fleet.profiles.profiles]
    mussels = [
        MusselResult(int(i), round(start_battery[int(i)], 6), round(float(u), 4),
                     sorted(dockings.get(int(i), []), key=lambda d: d["t_s"]), states, first,
                     profile=names[int(k)], samples_taken=int(a), samples_scheduled=int(b))
        for i, u, states, first, k, a, b in zip(rec.ids, uptime, state_s, first_depleted_s, fleet.profile, taken, due,
                                                 strict=True)
    ]
    apads = [row | apad_shares(apad_times.get(row["sysid"], {})) for row in apads]
    travelled = sum(v.state.distance_travelled_m for v in world.vehicles.values())
    stats = world.link.codec.stats
    homes = {m: (h.lat, h.lon) for m, h in world.homes.items()}
    reported = {m: why for loop in loops.values() for m, why in loop.status.off_position.items()}
    whereabouts = [
        {"id": a.mussel_id, "where": a.where, "detail": a.detail}
        for a in account(world.fleet.state, world.frame, homes, world.link.vehicles, world.fleet.params.seabed_depth_m,
                         reported)
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
        cost_m=round(outcome.cost_m, 3),
        active_avg=round(summary.avg_active, 4),
        wall_s=round(wall_s, 3),
        mussels=mussels,
        travelled_m=round(travelled, 3),
        cycles=outcome.cycles,
        end_reason=outcome.end_reason,
        out_dir=str(world.folder.path) if world.folder is not None else "",
        messages=messages,
        whereabouts=whereabouts,
        apads=apads,
        happened=happenings(world, outcome),
        **per_day(world, outcome),
        acoustic=world.acoustic.summary() if world.acoustic is not None else {},
        platform=str(world.platform),
    )


def per_day(world: World, outcome: Outcome) -> dict[str, Any]:
    """result.json's sim_day_s and days (`gcs.results.days`); nothing without the recorder's ledger."""
    days = world.fleet.recorder.days
    if days is None:
        return {}
    ids = tuple(a.system_id for a in world.scenario.apads)
    dockings = {a: [t for t, _ in loop.status.dockings] for a, loop in outcome.loops.items()}
    end = energy_now(world, ids)
    record = outcome.apad_record
    energy = record.energy_per_day(end, len(days.steps)) if record is not None and record.apad_ids == ids else \
        np.full((len(days.steps), len(ids), end.shape[1]), np.nan)
    return {"sim_day_s": round(days.day_us / 1e6, 3),
            "days": day_rows(days, world.fleet.recorder.ids.size, dockings, energy, ids)}


def happenings(world: World, outcome: Outcome) -> dict[str, Any]:
    """What happened that a user would want to know besides the figures, from the run's own records:
    the link faults injected and aPads failed on purpose, the aPads' failsafe holds (embedded SITL
    aPads: a real one's are on the aPad), the loop's link losses, Go Tos the failsafe preempted,
    steps given up at a bound, failed dockings by what became of the aMussel, planning steps a
    strategy failed, aPads lost to the swarm and the re-shares. Zeros are left out."""
    counts = world.events.counts
    options = world.options
    happened: dict[str, Any] = {}
    if options.faults is not None and options.faults.any:
        f = options.faults
        happened["faults"] = {k: v for k, v in (("loss", f.loss_frac), ("latency_s", f.latency_s),
                                                ("jitter_s", f.jitter_s), ("duplicate", f.duplicate_frac),
                                                ("outages_s", [list(w) for w in f.outages_s])) if v}
    if options.fail_apads:
        happened["failed_apads"] = [{"apad": sysid, "at_s": t_s} for sysid, t_s in options.fail_apads]
    if world.vehicles:
        happened["failsafe_holds"] = sum(v.modes.failsafe_holds for v in world.vehicles.values())
    for kind, name in (("link_lost", "link_losses"), ("goto_resumed", "gotos_resumed"), ("gave_up", "gave_up")):
        happened[name] = counts.get(kind, 0)
    happened["strategy_failures"] = sum(loop.status.strategy_failures for loop in outcome.loops.values())
    failed: Counter[str] = Counter()
    for loop in outcome.loops.values():
        failed.update(loop.status.failed_dockings)
    happened["failed_dockings"] = dict(sorted(failed.items()))  # by what became of the aMussel
    shares = outcome.shares
    if shares is not None:
        happened["reshares"] = max(shares.reshares - 1, 0)  # the first sharing is not a re-share
        happened["apads_lost"] = [{"apad": a, "at_s": round(us / 1e6, 2)}
                                  for a, us in sorted(shares.lost_since_us.items())]
    return {k: v for k, v in happened.items() if v}


def apad_rows(world: World, outcome: Outcome) -> list[dict[str, Any]]:
    """One row per aPad for result.json: its share, travel, dockings and how its time was spent."""
    loops = outcome.loops
    rows = []
    duration_s = world.scenario.mission.duration_s
    for sysid, loop in sorted(loops.items()):
        vehicle = world.vehicles.get(sysid)
        spent = loop.status.phase_s
        first = outcome.shares.first if outcome.shares is not None else None
        last = outcome.shares.partition if outcome.shares is not None else None
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
            "home_charges": loop.status.home_charges,
            **(_energy(vehicle.energy_counters) if vehicle is not None else {}),
            **({"lost_at_s": round(outcome.shares.lost_since_us[sysid] / 1e6, 2)}
               if outcome.shares is not None and sysid in outcome.shares.lost_since_us else {}),
        })
    return rows


def _energy(counters: EnergyCounters) -> dict[str, float]:
    """An embedded SITL aPad's energy, Wh (a real aPad's is on the aPad)."""
    return {"passed_wh": round(counters.passed_wh, 2), "drawn_wh": round(counters.drawn_wh, 2),
            "home_wh": round(counters.home_wh, 2)}


def write_endpoints(world: World, folder: RunFolder) -> None:
    """endpoints.json: the UDP ports a run over real sockets opened (ephemeral, so unknowable from
    outside otherwise): each aPad's, its fault proxy's and the GCS link's. Tests spray them."""
    apads = {str(s): v.transport for s, v in world.vehicles.items()}
    ports: dict[str, Any] = {
        "apad": {s: t.local_port for s, t in apads.items() if isinstance(t, UdpTransport)},
        "proxy": [p.listen_port for p in world.proxies],
        "gcs": world.link.udp_ports(),
    }
    folder.endpoints.write_text(json.dumps(ports) + "\n")


def write_outputs(world: World, result: RunResult, folder: RunFolder, apad_times: dict[int, ApadTimes],
                  record: ApadRecord | None = None) -> None:
    """traces.npz and result.json. traces.npz (format TRACES_FORMAT) holds what a report draws, at a
    bounded number of points: the recorder's traces (battery and state), the active count per step,
    each aPad's track (`record`), each aMussel's start and end position; a report reads it instead of
    replaying the GCS's log (`gcs.report.traces`)."""
    rec = world.fleet.recorder
    steps, battery = rec.battery_trace()
    _, state = rec.state_trace()
    start, end = world.start, world.fleet.state  # the start configuration's order may not be the ids'
    order = np.argsort(start.ids)[np.searchsorted(np.sort(start.ids), rec.ids)]
    end_lat, end_lon = world.frame.to_geodetic(end.x_m, end.y_m)
    arrays: dict[str, Any] = dict(
        ids=rec.ids, start_us=np.int64(rec.start_us), step_time_us=rec.step_time_us(), active_count=rec.active_count(),
        battery_steps=steps, battery=battery, battery_state=state, trace_ids=rec.trace_ids,
        **trace_arrays(rec, apad_times), traces_format=np.int64(TRACES_FORMAT),
        start_lat_deg=start.lat_deg[order], start_lon_deg=start.lon_deg[order], end_lat_deg=end_lat,
        end_lon_deg=end_lon, end_battery=end.battery_frac, end_state=end.state,
    )
    if record is not None:
        arrays |= record.track() | {"track_apad_ids": np.array(record.apad_ids, np.int64),
                                    "track_complete": np.bool_(record.complete)}
    np.savez_compressed(folder.traces, **arrays)
    folder.result.write_text(json.dumps(result.to_json(), indent=1) + "\n")
