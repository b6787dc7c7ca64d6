"""`vil report RUN_DIR -o OUT`: plots, a one-page HTML summary and GeoJSON of a recorded run.

    vil report runs/latest -o reports/pool12      # or runs/pool12-cautious-seed1-run1

Writes battery.png (every aMussel's battery over mission time), active.png (active aMussels
over time, the paper's Fig. 9), uptime.png (uptime per aMussel, eq. 3), track.png (the aPad's
track over the area), partition.png (several aPads: who serves which aMussels), index.html (the
Table II indices, beside the paper's where it ran the same thing) and run.geojson (the track and
the aMussels' positions, for GIS tools).

The figures come from the GCS log replayed through the console's model; the indices from
result.json when the run wrote one (headless runs), else from the same replay.
"""

from __future__ import annotations

import argparse
import html
import json
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from gcs.console.model import Snapshot
from gcs.mission import flags
from gcs.mission.results import PAPER_TABLE_II
from gcs.mission.scenario import ScenarioError
from gcs.records.replay import ReplayError, load_replay, run_files
from mussel_sim.geo import flat_m
from mussel_sim.vocabulary import MusselState

GREEN, RED, PURPLE, GREY, BLUE, ORANGE = "#16a34a", "#dc2626", "#a21caf", "#6b7280", "#2563eb", "#ea580c"


@dataclass(frozen=True)
class Indices:
    """The paper's Table II columns."""

    avg_uptime_pct: float
    max_uptime_pct: float
    min_uptime_pct: float
    cost_m: float
    active_avg: float
    source: str  # "result.json" or "replay"


def indices(result: dict[str, object], last: Snapshot) -> Indices:
    up = result.get("uptime")
    if isinstance(up, dict) and "cost_m" in result and "active_avg" in result:
        return Indices(float(up["avg"]), float(up["max"]), float(up["min"]), float(str(result["cost_m"])),
                       float(str(result["active_avg"])), "result.json")
    u = last.uptime_pct
    return Indices(float(u.mean()), float(u.max()), float(u.min()), last.cost_m,
                   float(last.hist_active.mean()) if last.hist_active.size else 0.0, "replay")


def write_report(run: str | Path, out: Path, scenario: str | Path | None = None) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")  # files only, never a window
    files = run_files(run)
    replay = load_replay(run, scenario)
    last = replay.frames[-1]
    out.mkdir(parents=True, exist_ok=True)
    ind = indices(files.result, last)
    title = _title(files.result, files.folder)
    written = [
        _battery_png(last, out / "battery.png", title),
        _active_png(last, out / "active.png", title),
        _uptime_png(last, out / "uptime.png", title),
        _track_png(replay.frames, out / "track.png", title),
        _geojson(replay.frames, out / "run.geojson"),
    ]
    shares = _partition_png(replay.frames, files.events, out / "partition.png", title)
    if shares is not None:
        written.append(shares)
    written.append(_html(files.result, ind, last, title, out / "index.html"))
    return written


def _title(result: dict[str, object], folder: Path) -> str:
    if "scenario" in result and "strategy" in result:
        return f"{result['scenario']} {result['strategy']} seed {result.get('seed', '?')}"
    return folder.name


def _minutes(snap: Snapshot) -> np.ndarray:
    return snap.hist_t_s / 60.0


def _figure(width_in: float = 8.0, height_in: float = 4.0):  # type: ignore[no-untyped-def]
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(width_in, height_in), dpi=110, layout="constrained")
    ax.grid(True, alpha=0.3)
    return fig, ax


def _save(fig, path: Path) -> Path:  # type: ignore[no-untyped-def]
    import matplotlib.pyplot as plt

    fig.savefig(path)
    plt.close(fig)
    return path


def _battery_png(snap: Snapshot, path: Path, title: str) -> Path:
    fig, ax = _figure()
    t = _minutes(snap)
    hist = 100.0 * snap.hist_battery.astype(np.float64)
    many = snap.mussel_ids.size > 24
    import matplotlib.pyplot as plt

    colours = plt.get_cmap("tab20" if not many else "viridis")
    for c, mussel in enumerate(snap.mussel_ids):
        colour = colours(c / snap.mussel_ids.size) if many else colours(c % 20)
        ax.plot(t, hist[:, c], color=colour, lw=0.8 if many else 1.2, alpha=0.5 if many else 0.9,
                label=None if many else f"{mussel}")
    ax.axhline(100 * snap.pool_threshold, color=GREY, ls="--", lw=1, label="pool threshold")
    ax.set(xlabel="mission time [min]", ylabel="battery [% of 3.6-4.2 V]", ylim=(0, 102),
           title=f"aMussel battery levels — {title}")
    ax.legend(title="aMussel", ncols=2 if not many else 1, fontsize=7, loc="center left", bbox_to_anchor=(1.0, 0.5))
    return _save(fig, path)


def _active_png(snap: Snapshot, path: Path, title: str) -> Path:
    fig, ax = _figure()
    t = _minutes(snap)
    ax.step(t, snap.hist_active, where="post", color=BLUE, lw=1.5, label="active aMussels")
    if snap.hist_active.size:
        mean = float(snap.hist_active.mean())
        ax.axhline(mean, color=ORANGE, ls="--", lw=1, label=f"mean {mean:.2f}")
    ax.set(xlabel="mission time [min]", ylabel="active aMussels [count]", ylim=(0, snap.mussel_ids.size + 0.5),
           title=f"Active aMussels over time — {title}")
    ax.yaxis.get_major_locator().set_params(integer=True)
    ax.legend(loc="lower left")
    return _save(fig, path)


def _uptime_png(snap: Snapshot, path: Path, title: str) -> Path:
    fig, ax = _figure()
    ids = [str(i) for i in snap.mussel_ids]
    ax.bar(ids, snap.uptime_pct, color=GREEN)
    avg = float(snap.uptime_pct.mean()) if snap.uptime_pct.size else 0.0
    ax.axhline(avg, color=ORANGE, ls="--", lw=1, label=f"average {avg:.1f} %")
    ax.set(xlabel="aMussel id", ylabel="uptime [% of mission steps active]", ylim=(0, 118),
           title=f"Uptime per aMussel (eq. 3) — {title}")
    if len(ids) > 30:
        ax.set_xticks(ids[:: max(len(ids) // 20, 1)])
    ax.legend(loc="upper right")
    return _save(fig, path)


def _track(frames: list[Snapshot]) -> tuple[np.ndarray, np.ndarray]:
    lat = np.array([f.apad_lat_deg if f.apad_lat_deg is not None else np.nan for f in frames])
    lon = np.array([f.apad_lon_deg if f.apad_lon_deg is not None else np.nan for f in frames])
    ok = np.isfinite(lat) & np.isfinite(lon)
    return lat[ok], lon[ok]


def _first_positions(frames: list[Snapshot]) -> tuple[np.ndarray, np.ndarray]:
    """Where each aMussel was first heard (its deployment position)."""
    last = frames[-1]
    lat, lon = np.full(last.mussel_ids.size, np.nan), np.full(last.mussel_ids.size, np.nan)
    for f in frames:
        n = f.mussel_ids.size
        fill = np.isnan(lat[:n]) & np.isfinite(f.lat_deg)
        lat[:n][fill], lon[:n][fill] = f.lat_deg[fill], f.lon_deg[fill]
    return lat, lon


def _track_png(frames: list[Snapshot], path: Path, title: str) -> Path:
    last = frames[-1]
    lat, lon = _track(frames)
    m_lat, m_lon = _first_positions(frames)
    every = np.concatenate([lat, m_lat, last.outline_lat_deg]), np.concatenate([lon, m_lon, last.outline_lon_deg])
    lat0, lon0 = float(np.nanmean(every[0])), float(np.nanmean(every[1]))
    fig, ax = _figure(8.0, 5.0)
    if last.outline_lat_deg.size:
        ox, oy = flat_m(last.outline_lat_deg, last.outline_lon_deg, lat0, lon0)
        ax.plot(ox, oy, color=GREY, lw=1.5, label="area")
    mx, my = flat_m(m_lat, m_lon, lat0, lon0)
    ax.scatter(mx, my, s=30, color=GREEN, edgecolor="black", lw=0.5, zorder=3, label="aMussel start")
    for i, mussel in enumerate(last.mussel_ids):
        if np.isfinite(mx[i]):
            ax.annotate(str(mussel), (mx[i], my[i]), textcoords="offset points", xytext=(4, 4), fontsize=7)
    tx, ty = flat_m(lat, lon, lat0, lon0)
    ax.plot(tx, ty, color=BLUE, lw=1.2, label="aPad track")
    if tx.size:
        ax.plot(tx[:1], ty[:1], "o", color=BLUE, label="aPad start")
        ax.plot(tx[-1:], ty[-1:], "D", color=ORANGE, label="aPad end")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set(xlabel="east [m]", ylabel="north [m]", title=f"aPad track over the area — {title}")
    ax.legend(fontsize=8, loc="center left", bbox_to_anchor=(1.0, 0.5))
    return _save(fig, path)


def _reshares(events_path: Path) -> list[dict[str, object]]:
    """The swarm's re-share events (which aPad serves which aMussels), oldest first."""
    if not events_path.exists():
        return []
    out = []
    for line in events_path.read_text().splitlines():
        try:
            event = json.loads(line)
        except json.JSONDecodeError:
            continue  # a torn last line after a crash
        if not isinstance(event, dict) or event.get("event") != "reshare":
            continue
        if not isinstance(event.get("t_s"), int | float):
            continue
        shares = event.get("shares")
        if isinstance(shares, dict) and all(isinstance(ids, list) and all(type(m) is int for m in ids)
                                            for ids in shares.values()):
            out.append(event)  # an older run's event (counts, not ids) or a damaged one is left out
    return out


def _partition_png(frames: list[Snapshot], events_path: Path, path: Path, title: str) -> Path | None:
    """Several aPads: the k-means shares of the fleet, one panel per sharing (the first, then each
    re-share after an aPad was lost or came back). None for a one-aPad run."""
    reshares = _reshares(events_path)
    if not reshares:
        return None
    import matplotlib.pyplot as plt

    last = frames[-1]
    m_lat, m_lon = _first_positions(frames)
    lat0, lon0 = float(np.nanmean(m_lat)), float(np.nanmean(m_lon))
    mx, my = flat_m(m_lat, m_lon, lat0, lon0)
    where = {int(m): k for k, m in enumerate(last.mussel_ids)}
    panels = reshares[:1] + reshares[1:][-2:]  # the first sharing and the last two re-shares
    fig, axes = plt.subplots(1, len(panels), figsize=(5.5 * len(panels), 4.5), dpi=110, layout="constrained",
                             squeeze=False)
    colours = plt.get_cmap("tab10")
    for ax, event in zip(axes[0], panels, strict=True):
        if last.outline_lat_deg.size:
            ox, oy = flat_m(last.outline_lat_deg, last.outline_lon_deg, lat0, lon0)
            ax.plot(ox, oy, color=GREY, lw=1.2)
        shares = event["shares"]
        assert isinstance(shares, dict)
        for apad, ids in sorted(shares.items(), key=lambda kv: int(kv[0])):
            colour = colours((int(apad) - 1) % 10)  # an aPad keeps its colour from panel to panel
            rows = [where[int(m)] for m in ids if int(m) in where]
            ax.scatter(mx[rows], my[rows], s=22, color=colour, edgecolor="black", lw=0.4,
                       label=f"aPad {apad}: {len(ids)}")
            if rows:
                ax.plot(np.mean(mx[rows]), np.mean(my[rows]), "X", ms=11, color=colour, mec="black")
        lost = event.get("lost")
        gone = ", ".join(str(a) for a in lost) if isinstance(lost, list) else ""
        what = f"t = {float(str(event['t_s'])) / 60:.1f} min" + (f", aPad {gone} lost" if gone else "")
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(True, alpha=0.3)
        ax.set(xlabel="east [m]", ylabel="north [m]", title=what)
        ax.legend(fontsize=7, loc="best")
    fig.suptitle(f"The fleet shared among the aPads (k-means, balanced; X: share centre) — {title}")
    return _save(fig, path)


def _geojson(frames: list[Snapshot], path: Path) -> Path:
    last = frames[-1]
    lat, lon = _track(frames)
    m_lat, m_lon = _first_positions(frames)
    features: list[dict[str, object]] = [{
        "type": "Feature",
        "properties": {"name": "aPad track", "samples_per_s": 1},
        "geometry": {"type": "LineString", "coordinates": [[round(x, 7), round(y, 7)] for x, y in zip(lon, lat,
                                                                                                    strict=True)]},
    }]
    for i, mussel in enumerate(last.mussel_ids):
        for kind, la, lo in (("start", m_lat[i], m_lon[i]), ("end", last.lat_deg[i], last.lon_deg[i])):
            if np.isfinite(la) and np.isfinite(lo):
                features.append({
                    "type": "Feature",
                    "properties": {"amussel_id": int(mussel), "position": kind,
                                   "uptime_pct": round(float(last.uptime_pct[i]), 3),
                                   "state": MusselState(int(last.state[i])).name.lower()},
                    "geometry": {"type": "Point", "coordinates": [round(float(lo), 7), round(float(la), 7)]},
                })
    path.write_text(json.dumps({"type": "FeatureCollection", "features": features}, indent=1) + "\n")
    return path


def _html(result: dict[str, object], ind: Indices, last: Snapshot, title: str, path: Path) -> Path:
    rows = [("this run", ind.avg_uptime_pct, ind.max_uptime_pct, ind.min_uptime_pct, ind.cost_m, ind.active_avg)]
    paper = PAPER_TABLE_II.get((str(result.get("scenario")), str(result.get("strategy"))))
    if paper is not None:
        rows.append(("paper (Table II)", *paper))
    table = "\n".join(
        f"<tr><td>{html.escape(name)}</td><td>{a:.2f}</td><td>{mx:.2f}</td><td>{mn:.2f}</td>"
        f"<td>{c:.1f}</td><td>{act:.2f}</td></tr>"
        for name, a, mx, mn, c, act in rows
    )
    facts = [("mission time", f"{last.t_s / 60:.1f} min"), ("aMussels", str(last.mussel_ids.size)),
             ("end", str(result.get("end_reason") or last.ended or "-")), ("indices from", ind.source)]
    facts_html = "".join(f"<li><b>{html.escape(k)}</b>: {html.escape(v)}</li>" for k, v in facts)
    drawn = (path.parent / "partition.png").exists()
    partition = '<img src="partition.png" alt="the fleet shared among the aPads">' if drawn else ""
    page = f"""<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>vil report: {html.escape(title)}</title>
<style>
body {{ font-family: sans-serif; max-width: 1100px; margin: 1em auto; }}
table {{ border-collapse: collapse; }} td, th {{ border: 1px solid #ccc; padding: 4px 10px; text-align: right; }}
td:first-child {{ text-align: left; }} img {{ width: 49%; }}
</style></head><body>
<h1>{html.escape(title)}</h1>
<ul>{facts_html}</ul>
<table><tr><th>run</th><th>avg uptime %</th><th>max uptime %</th><th>min uptime %</th><th>cost m</th>
<th>active aMussels (mean)</th></tr>
{table}
</table>
<p><img src="battery.png" alt="battery levels"> <img src="active.png" alt="active aMussels over time">
<img src="uptime.png" alt="uptime per aMussel"> <img src="track.png" alt="aPad track">
{partition}</p>
<p>GeoJSON of the aPad track and the aMussels' start and end positions: <a href="run.geojson">run.geojson</a></p>
</body></html>
"""
    path.write_text(page)
    return path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("run", metavar="RUN_DIR", help="a run folder (gcs.tlog, events.jsonl, result.json)")
    parser.add_argument("-o", "--out", type=flags.writable_dir, metavar="OUT", required=True,
                        help="folder for the report")
    parser.add_argument("--scenario", metavar="FILE", help="scenario TOML (default: the one the run names)")


def run(args: argparse.Namespace) -> int:
    try:
        written = write_report(args.run, Path(args.out), args.scenario)
    except (ReplayError, ScenarioError, OSError) as exc:
        print(f"vil report: {exc}", file=sys.stderr)
        return 2
    for path in written:
        print(path)
    return 0
