"""`vil report RUN [RUN ...] [-o OUT]`: figures, a page that reads on its own, and GeoJSON of a
recorded run; several runs: the same for each, and a page that compares them.

    vil report runs/latest                          # into runs/latest/report/
    vil report runs/latest -o reports/pool12        # or runs/pool12-cautious-seed1-run1
    vil report runs/pool12-cautious-seed1-run1 runs/pool12-greedy-seed1-run1 -o reports/cautious-vs-greedy

One run writes, in OUT: index.html (what ran, the Table II indices beside the paper's, a row per
aMussel and per aPad, every figure with how to read it, the event timeline), battery.png,
battery_map.png, states.png, active.png (the paper's Fig. 9), uptime.png (eq. 3; never-collected
and depleted aMussels marked), track.png (metres from the first aPad's home, stated on the axis),
phases.png (each aPad's time per phase), days.png (runs of two simulated days or more: uptime,
alive, charges and energy per day), partition.png (several aPads: who serves which
aMussels) and run.geojson (RFC 7946: area, tracks with timestamps, a point per aMussel).

Several runs write each run's report in OUT/RUN_NAME/ and, in OUT, index.html with a row per run
and compare_active.png, compare_cost.png, compare_uptime.png overlaying them.

Colours: matplotlib's petroff10 qualitative sequence (chosen for colour-vision deficiencies) with
three line styles and markers, so up to 30 aMussels or runs stay apart; colour maps: cividis.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

from gcs.cli import flags
from gcs.records.playback import ReplayError
from gcs.records.run_folder import RunFolder
from gcs.report import figures as figs
from gcs.report import maps
from gcs.report import per_day as days
from gcs.report.acoustic_section import acoustic_html
from gcs.report.compare import write_comparison
from gcs.report.geojson import write_geojson
from gcs.report.load import load_run
from gcs.report.page import Figure, write_page
from gcs.report.per_week import LONG_DAYS
from gcs.report.run_data import RunData
from gcs.report.style import use_files_only
from gcs.scenario.reader import ScenarioError

Draw = Callable[[RunData, Path], "Path | None"]

# file, drawing (None: nothing to draw for this run), title, how to read it
FIGURES: tuple[tuple[str, Draw, str, str], ...] = (
    ("uptime.png", figs.uptime_png, "Uptime per aMussel",
     "The share of mission steps each aMussel was measuring (eq. 3: active, and sinking after its release "
     "unless the scenario says otherwise), the dashed line the average. The number "
     "in a bar counts its dockings; a hatched bar was never collected; a cross above a bar marks an aMussel "
     "that ran flat, with its minutes depleted. In a swarm the bar's colour is the aPad whose share it was."),
    ("active.png", figs.active_png, "Active aMussels over time",
     "How many aMussels were measuring at each mission second (the paper's Fig. 9); the dashed line is the "
     "mean, the paper's active index."),
    ("battery.png", figs.battery_png, "Battery levels",
     "Each aMussel's battery over mission time, each in its own colour, line style and marker; below the "
     "dashed pool threshold an aMussel is a charging candidate. Rises are charging on an aPad."),
    ("battery_map.png", figs.battery_map_png, "Battery per aMussel (colour map)",
     "The same batteries as rows of colour (cividis: dark low, yellow full), one row per aMussel; white "
     "before it was first heard."),
    ("states.png", figs.states_png, "States over time and time per state",
     "Left: each aMussel's state at each mission second. Right: its minutes in each state, stacked. "
     "Purple is docked (charging), dark grey depleted; the short yellow, orange and cyan stretches are "
     "surfacing, floating (waiting for the aPad) and sinking."),
    ("track.png", maps.track_png, "aPad track over the area",
     "Each aPad's path (circle: start, diamond: end) and each aMussel where it was deployed, in metres east "
     "and north of the origin marked + (its position is on the x axis label)."),
    ("phases.png", figs.phases_png, "aPad time per phase",
     "Top: each aPad's mission minutes by its loop's phase (idle: waiting for enough charging candidates; "
     "the planning phases take no time). Below, for runs that recorded it: by what the aPad was doing: "
     "travelling (a Go To in progress), docking (a Dock or Undock in progress), holding (the rest)."),
    ("days.png", days.days_png, "Per simulated day",
     "The aMussels' days (86,400 s / theta of mission time each): above, the fleet's mean uptime that day (bars) "
     "and the aMussels alive at its end (line); below, the aMussels each aPad charged that day (line) and the "
     f"energy it passed into them (dotted). Past {LONG_DAYS} days, by week: the fleet's uptime as a band from the "
     "week's lowest to its highest day around the week's mean, and each aPad's aMussels charged and Wh passed a "
     "day (the week's mean) as heat maps of aPad x week. Every day is in the table of the same name."),
    ("partition.png", maps.partition_png, "The fleet shared among the aPads",
     "Which aPad served which aMussels (k-means, balanced; in an acoustic fleet each aMussel joins the nearest "
     "share with room as it is first heard): the first sharing, then the last re-shares after an aPad was lost "
     "or came back. X marks each share's centre."),
)


def write_report(run: str | Path, out: Path, scenario: str | Path | None = None) -> list[Path]:
    return write_run_report(load_run(run, scenario), out)


def write_run_report(data: RunData, out: Path) -> list[Path]:
    use_files_only()
    out.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    shown: list[Figure] = []
    for file, draw, title, caption in FIGURES:
        (out / file).unlink(missing_ok=True)  # a figure this run has none of must not stay from an older report
        path = draw(data, out / file)
        if path is not None:
            written.append(path)
            shown.append(Figure(file, title, caption))
    written.append(write_geojson(data, out / "run.geojson"))
    per_day = days.days_table(data) if len(days.day_rows(data)) > 1 else ""
    written.append(write_page(data, shown, out / "index.html", days_html=per_day, acoustic_html=acoustic_html(data)))
    return written


def write_reports(runs: Sequence[str | Path], out: Path, scenario: str | Path | None = None) -> list[Path]:
    """Several runs: each one's report in OUT/NAME/, and the comparison in OUT."""
    data = [load_run(run, scenario) for run in runs]
    folders: list[str] = []
    written: list[Path] = []
    for run in data:
        name, k = run.name, 1
        while name in folders:  # the same folder name twice (e.g. two `latest`): keep both
            k += 1
            name = f"{run.name}-{k}"
        folders.append(name)
        written += write_run_report(run, out / name)
    return written + write_comparison(data, folders, out)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("runs", nargs="+", metavar="RUN_DIR",
                        help="run folder(s) (gcs.tlog, events.jsonl, result.json); several: compared")
    parser.add_argument("-o", "--out", type=flags.writable_dir, metavar="OUT",
                        help="folder for the report (one run: default RUN_DIR/report; several: required)")
    parser.add_argument("--scenario", metavar="FILE", help="scenario TOML (default: the one each run names)")


def run(args: argparse.Namespace) -> int:
    runs: list[str] = args.runs
    if len(runs) > 1 and args.out is None:
        print("vil report: several runs need -o OUT, the folder for the comparison", file=sys.stderr)
        return 2
    try:
        if len(runs) == 1:
            data = load_run(runs[0], args.scenario)
            written = write_run_report(data, Path(args.out) if args.out is not None else RunFolder(data.folder).report)
        else:
            written = write_reports(runs, Path(args.out), args.scenario)
    except (ReplayError, ScenarioError, OSError) as exc:
        print(f"vil report: {exc}", file=sys.stderr)
        return 2
    for path in written:
        print(path)
    return 0
