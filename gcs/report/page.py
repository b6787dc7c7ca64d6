"""index.html: one run's report as a page that reads on its own, every asset beside it (no outside
URL, no script): what ran, the Table II indices, a row per aMussel and per aPad, the figures with
how to read them, and the event timeline from events.jsonl."""

from __future__ import annotations

import html
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from gcs.records.events import Event
from gcs.report.run_data import APAD_SHARES, RunData, as_list
from gcs.results.run_result import PAPER_TABLE_II
from missiontime import mm_ss

MAX_EVENTS = 3000  # rows of the timeline; a longer log is cut, and the page says so

STYLE = """
body { font-family: system-ui, sans-serif; max-width: 1150px; margin: 1em auto; padding: 0 1em; color: #111827; }
h1 { margin-bottom: 0.2em; } h2 { border-bottom: 1px solid #d1d5db; padding-bottom: 0.2em; margin-top: 1.6em; }
table { border-collapse: collapse; margin: 0.5em 0; font-size: 0.92em; }
td, th { border: 1px solid #d1d5db; padding: 3px 9px; text-align: right; }
th { background: #f3f4f6; } td.text, th.text { text-align: left; }
tr.flag td { background: #fef3c7; }
dl.facts { display: grid; grid-template-columns: max-content auto; gap: 2px 14px; }
dl.facts dt { font-weight: 600; } dl.facts dd { margin: 0; }
figure { margin: 1.2em 0; } figure img { max-width: 100%; border: 1px solid #e5e7eb; }
figcaption { font-size: 0.9em; color: #374151; max-width: 60em; }
.scroll { max-height: 32em; overflow-y: auto; border: 1px solid #e5e7eb; display: inline-block; }
.scroll th { position: sticky; top: 0; }
caption { caption-side: bottom; text-align: left; font-size: 0.85em; color: #4b5563; padding-top: 4px; }
nav a { margin-right: 1em; }
"""


@dataclass(frozen=True)
class Figure:
    file: str  # beside the page
    title: str
    caption: str  # how to read it


def table(headers: Sequence[str], rows: Sequence[Sequence[object]], caption: str = "", text_cols: int = 1,
          flagged: Sequence[bool] = (), text_right: int = 0) -> str:
    """An HTML table; the first `text_cols` and the last `text_right` columns left-aligned (words, not
    numbers), flagged rows highlighted."""
    def cell(k: int, value: object, tag: str) -> str:
        align = ' class="text"' if k < text_cols or k >= len(headers) - text_right else ""
        return f"<{tag}{align}>{html.escape(str(value))}</{tag}>"

    head = "<tr>" + "".join(cell(k, h, "th") for k, h in enumerate(headers)) + "</tr>"
    body = "\n".join(
        ('<tr class="flag">' if k < len(flagged) and flagged[k] else "<tr>")
        + "".join(cell(j, v, "td") for j, v in enumerate(row)) + "</tr>"
        for k, row in enumerate(rows))
    cap = f"<caption>{html.escape(caption)}</caption>" if caption else ""
    return f"<table>{cap}\n{head}\n{body}\n</table>"


def figures_html(figures: Sequence[Figure]) -> str:
    return "\n".join(
        f'<figure id="{html.escape(Path(f.file).stem)}"><h3>{html.escape(f.title)}</h3>'
        f'<img src="{html.escape(f.file)}" alt="{html.escape(f.title)}">'
        f"<figcaption>{html.escape(f.caption)}</figcaption></figure>"
        for f in figures)


def page(title: str, body: str) -> str:
    return (f'<!doctype html>\n<html lang="en"><head><meta charset="utf-8">'
            f'<meta name="viewport" content="width=device-width, initial-scale=1">'
            f"<title>{html.escape(title)}</title>\n<style>{STYLE}</style></head>\n<body>\n{body}\n</body></html>\n")


def indices_rows(data: RunData, name: str = "this run") -> list[list[object]]:
    """The Table II row of a run, and the paper's beside it when the paper ran the same thing."""
    i = data.indices
    rows: list[list[object]] = [[name, f"{i.avg_uptime_pct:.2f}", f"{i.max_uptime_pct:.2f}",
                                 f"{i.min_uptime_pct:.2f}", f"{i.cost_m:.1f}", f"{i.active_avg:.2f}"]]
    paper = PAPER_TABLE_II.get((str(data.result.get("scenario")), str(data.result.get("strategy"))))
    if paper is not None:
        a, mx, mn, c, act = paper
        rows.append(["paper (Table II)", f"{a:.2f}", f"{mx:.2f}", f"{mn:.2f}", f"{c:.1f}", f"{act:.2f}"])
    return rows


INDEX_HEADERS = ("run", "avg uptime %", "max uptime %", "min uptime %", "cost m", "active aMussels (mean)")


def write_page(data: RunData, figures: Sequence[Figure], path: Path, geojson: str = "run.geojson",
               days_html: str = "", acoustic_html: str = "") -> Path:
    """`days_html`: the per-day section's body (`gcs.report.per_day.days_table`), none if empty;
    `acoustic_html`: belief against truth (`gcs.report.acoustic_section`), none if empty."""
    sections = [
        f"<h1>{html.escape(data.title)}</h1>",
        "<nav>" + " ".join(f'<a href="#{a}">{t}</a>' for a, t in (("summary", "Summary"), ("amussels", "aMussels"),
                                                                   ("apads", "aPads"),
                                                                   *((("days", "Per day"),) if days_html else ()),
                                                                   *((("knowledge", "Belief vs truth"),)
                                                                     if acoustic_html else ()),
                                                                   ("figures", "Figures"),
                                                                   ("events", "Event timeline"))) + "</nav>",
        _facts(data),
        '<h2 id="summary">Summary (the paper\'s Table II indices)</h2>',
        table(INDEX_HEADERS, indices_rows(data),
              "uptime: the share of mission steps an aMussel was active (eq. 3); cost: metres the aPad was sent "
              "(aPad to each Go To target, summed); active: aMussels measuring, averaged over the mission. "
              f"Indices from {data.indices.source}."),
        '<h2 id="amussels">aMussels</h2>', _mussel_table(data),
        '<h2 id="apads">aPads</h2>', _apad_table(data),
        *(('<h2 id="days">Per simulated day</h2>', days_html) if days_html else ()),
        *(('<h2 id="knowledge">What the GCS knew: the acoustic channel, belief against truth</h2>', acoustic_html)
          if acoustic_html else ()),
        '<h2 id="figures">Figures</h2>', figures_html(figures),
        '<h2 id="events">Event timeline</h2>', _timeline(data.events),
        "<h2>Files</h2>",
        f'<p>For GIS tools: <a href="{html.escape(geojson)}">{html.escape(geojson)}</a> (RFC 7946): the area, '
        "each aPad's track with a timestamp per position (<code>times</code>), and one point per aMussel "
        "with its figures.</p>",
    ]
    path.write_text(page(f"vil report: {data.title}", "\n".join(sections)), encoding="utf-8")
    return path


def _facts(data: RunData) -> str:
    r = data.result
    facts = [
        ("run folder", str(data.folder.resolve())),
        ("scenario", str(r.get("scenario") or (data.scenario.name if data.scenario else "-"))),
        ("strategy", data.strategy), ("seed", str(r.get("seed", "-"))),
        ("mission time", f"{data.end_s / 3600:.1f} of {data.duration_s / 3600:.1f} h" if data.duration_s > 6 * 3600
         else f"{data.end_s / 60:.1f} of {data.duration_s / 60:.1f} min"),
        ("ended", data.end_reason),
        ("aMussels", str(data.ids.size)), ("aPads", ", ".join(str(t.system_id) for t in data.tracks)),
        ("maps' origin (0, 0)", data.origin.text()),
    ]
    items = "".join(f"<dt>{html.escape(k)}</dt><dd>{html.escape(v)}</dd>" for k, v in facts)
    return f'<dl class="facts">{items}</dl>'


def _pct(x: float) -> str:
    return "-" if x != x else f"{100 * x:.0f}"  # NaN: never heard


def _mussel_table(data: RunData) -> str:
    rows, flagged = [], []
    for m in data.mussels:
        notes = [w for w, on in (("never collected", m.never_collected), ("depleted", m.depleted)) if on]
        first = "-" if m.first_depleted_s is None else mm_ss(m.first_depleted_s)
        rows.append([m.id, m.apad or "-", _pct(m.start_battery), _pct(m.end_battery), f"{m.uptime_pct:.1f}",
                     m.dockings, first, f"{m.depleted_s / 60:.1f}", m.end_state, ", ".join(notes)])
        flagged.append(bool(notes))
    headers = ("aMussel", "aPad", "start battery %", "end battery %", "uptime %", "dockings", "ran flat at",
               "depleted min", "state at the end", "notes")
    return table(headers, rows, "Highlighted: aMussels never collected or depleted for a while.", flagged=flagged,
                 text_right=2)


def _apad_table(data: RunData) -> str:
    apads = [a for a in as_list(data.result.get("apads")) if isinstance(a, dict)]
    if apads:
        shares = [k for k in APAD_SHARES if all(k in a for a in apads)]  # newer runs: time by activity
        rows = [[a.get("sysid", "-"), len(as_list(a.get("mussels"))), f"{float(a.get('cost_m', 0.0)):.1f}",
                 f"{float(a.get('travelled_m', 0.0)):.1f}", a.get("dockings", "-"), a.get("cycles", "-"),
                 f"{100 * float(a.get('idle_share', 0.0)):.0f}", *(f"{100 * float(a[k]):.0f}" for k in shares),
                 a.get("end_reason", "-")] for a in apads]
        headers = ("aPad", "aMussels served", "cost m", "travelled m", "dockings", "cycles", "idle %",
                   *(k.replace("_share", " %") for k in shares), "ended")
        return table(headers, rows, "From result.json; idle: waiting for enough charging candidates"
                     + ("; travelling, docking, holding: the aPad's time by what it was doing." if shares else "."),
                     text_right=1)
    rows = [[t.system_id, f"{float(t.cost_m[-1]) if t.cost_m.size else 0.0:.1f}", t.t_s.size] for t in data.tracks]
    return table(("aPad", "cost m", "seconds heard"), rows, "From the replayed log (the run wrote no result.json).")


def _listed(value: object) -> str:
    return ", ".join(str(v) for v in value) or "none" if isinstance(value, list) else str(value)


def _details(ev: Event) -> str:
    words = []
    for key, value in ev.fields.items():
        if key == "apad":
            continue
        if key == "mussel":
            words.append(f"aMussel {value}")
        elif key in ("phase", "why", "reason"):
            words.append(str(value))
        elif key == "slot":
            words.append(f"slot {value}")
        elif key == "route" and isinstance(value, list):
            words.append("route " + " → ".join(str(v) for v in value))
        elif key == "shares" and isinstance(value, dict):
            words += [f"aPad {a} serves {_listed(ids)}" for a, ids in value.items()]
        elif isinstance(value, list):
            words.append(f"{key.replace('_', ' ')}: {_listed(value)}")
        elif key.endswith("_m") and isinstance(value, int | float):
            words.append(f"{key[:-2].replace('_', ' ')} {value:.1f} m")
        else:
            words.append(f"{key.replace('_', ' ')}: {value}")
    return "; ".join(words)


def _timeline(events: Sequence[Event]) -> str:
    if not events:
        return "<p>The run left no events.jsonl.</p>"
    shown = events[:MAX_EVENTS]
    swarm = any("apad" in ev.fields for ev in shown)  # a swarm's loops name their aPad
    rows = [[mm_ss(ev.t_s), *([ev.fields.get("apad", "-")] if swarm else []), ev.kind.replace("_", " "),
             _details(ev)] for ev in shown]
    headers = ("time", *(["aPad"] if swarm else []), "event", "details")
    cut = f" The first {MAX_EVENTS} of {len(events)} are shown." if len(events) > MAX_EVENTS else ""
    caption = f"{len(events)} events from events.jsonl, in mission time (mm:ss).{cut}"
    return f'<div class="scroll">{table(headers, rows, caption, text_cols=len(headers))}</div>'
