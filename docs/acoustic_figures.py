"""docs/acoustic.md's figure and table: delivery against range, and the TDMA frames of shipped scenarios.

    python docs/acoustic_figures.py --figure docs/acoustic-delivery.png

Delivery probability against range for 16- and 64-byte packets under the default channel (the
scenario's `[acoustic]` defaults: acoustic/params.py), and the TDMA frame (slot and frame length) of
each scenario named by --scenarios.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.table import Table

from acoustic.params import AcousticParams
from acoustic.per import success_probability
from acoustic.propagation import snr_db
from gcs.scenario.reader import ScenarioError, load_scenario
from gcs.scenario.tdma_frame import area_range_m, scenario_frame

PAYLOADS = (16, 64)


def delivery_figure(path: Path, params: AcousticParams) -> list[tuple[int, float, float]]:
    """Draw delivery against range; the (payload, range at 90 %, range at 10 %) of each curve."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ranges = np.linspace(1.0, 3000.0, 600)
    snr = snr_db(ranges, params)
    fig, ax = plt.subplots(figsize=(7.0, 4.2))
    marks = []
    for n in PAYLOADS:
        ok = success_probability(snr, n, params)
        ax.plot(ranges, ok, label=f"{n}-byte payload ({0.105 + (n + 16) * 0.0125:.3f} s on the water)")
        marks.append((n, float(ranges[np.argmax(ok < 0.9)]), float(ranges[np.argmax(ok < 0.1)])))
    ax.set_xlabel("range (m)")
    ax.set_ylabel("delivery probability")
    ax.set_ylim(-0.02, 1.08)
    ax.grid(alpha=0.3)
    ax.set_title("nanomodem v3: 168 dB re 1 uPa, 28 kHz (Thorp), 20 log R, noise 50 dB/Hz over 8 kHz")
    ax.title.set_fontsize(9)
    for r in (500.0, 1000.0, 1500.0, 2000.0, 2500.0):
        ax.annotate(f"SNR {float(snr_db(r, params)):.0f} dB", (r, 1.0), textcoords="offset points", xytext=(0, 6),
                    ha="center", fontsize=7, color="0.4")
    ax.legend(loc="lower left")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return marks


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--figure", type=Path, default=Path("docs/acoustic-delivery.png"), metavar="PNG")
    parser.add_argument("--scenarios", nargs="+", default=["pool12", "bay24", "bay120"], metavar="NAME")
    args = parser.parse_args(argv)
    params = AcousticParams()
    marks = delivery_figure(args.figure, params)
    print(f"wrote {args.figure}")
    for n, r90, r10 in marks:
        print(f"{n}-byte packets: delivered with p >= 0.9 to {r90:,.0f} m, p >= 0.1 to {r10:,.0f} m")
    table = Table(title="TDMA frames (a slot: a 64-byte packet + the largest delay over the area + the guard)")
    for column in ("scenario", "aMussels", "aPads", "largest range (m)", "slot (s)", "frame (s)"):
        table.add_column(column, justify="left" if column == "scenario" else "right")
    for name in args.scenarios:
        try:
            scenario = load_scenario(name)
        except ScenarioError as exc:
            print(f"docs.acoustic_figures: {exc}", file=sys.stderr)
            return 2
        frame = scenario_frame(scenario)
        table.add_row(scenario.name, str(scenario.fleet.count), str(len(scenario.apads)),
                      f"{area_range_m(scenario):,.1f}", f"{frame.slot_s:.3f}", f"{frame.frame_s:.2f}")
    Console(width=120).print(table)
    return 0


if __name__ == "__main__":
    sys.exit(main())
