"""An acoustic run's section of the report: what the GCS knew against what was so (result.json's `acoustic`,
`gcs.acoustic_net.network.AcousticNetwork.summary`).

One line of what the channel carried (the TDMA frame, reports heard of sent, call-ups and their
retries, drops by reason), then belief against truth per aMussel: the battery the planner believed
(the last report run down by eq. 1) against the simulator's, sampled every 10 s of mission time,
and how old the knowledge got.
"""

from __future__ import annotations

import html
from typing import Any

from gcs.report.page import table
from gcs.report.run_data import RunData, as_list

CAPTION = ("Belief against truth, sampled every 10 s of mission time: the battery the planner believed "
           "(its last report, run down by eq. 1 since it was made) against the simulator's. Age: mission seconds "
           "since the report it knew was made. Highlighted: knowledge older than 10 minutes at some point "
           "(the planner leaves such an aMussel out).")
STALE_FLAG_S = 600.0


def acoustic_html(data: RunData) -> str:
    """The section's body, or "" for a run without the acoustic channel."""
    a = data.result.get("acoustic")
    if not isinstance(a, dict) or not a:
        return ""
    counts = a.get("counts", {}) if isinstance(a.get("counts"), dict) else {}
    fleet = a.get("fleet", {}) if isinstance(a.get("fleet"), dict) else {}
    k: dict[str, Any] = a.get("knowledge", {}) if isinstance(a.get("knowledge"), dict) else {}
    dropped = a.get("dropped", {}) if isinstance(a.get("dropped"), dict) else {}
    calls = int(counts.get("call_ups_acked", 0)) + int(counts.get("call_ups_unacked", 0))
    said = (f"TDMA frame {float(a.get('frame_s', 0.0)):.2f} s ({len(as_list(a.get('slots')))} slots of "
            f"{float(a.get('slot_s', 0.0)):.2f} s); {int(counts.get('reports_heard', 0)):,} of "
            f"{int(fleet.get('reports_sent', 0)):,} status reports heard; call-ups acknowledged "
            f"{int(counts.get('call_ups_acked', 0))} of {calls} ({int(counts.get('call_up_retries', 0))} retries); "
            f"knowledge {float(k.get('age_median_s', 0.0)):.1f} s old at the median, "
            f"{float(k.get('age_max_s', 0.0)):.0f} s at most; battery believed within "
            f"{100 * float(k.get('battery_error_mean', 0.0)):.2f} % of the truth on average "
            f"(at worst {100 * float(k.get('battery_error_max', 0.0)):.2f} %)")
    if dropped:
        said += "; dropped: " + ", ".join(f"{reason} {n}" for reason, n in sorted(dropped.items()))
    per = [p for p in as_list(k.get("per_mussel")) if isinstance(p, dict)]
    rows = [[p.get("mussel_id", "-"), f"{100 * float(p.get('battery_error_mean', 0.0)):.2f}",
             f"{100 * float(p.get('battery_error_max', 0.0)):.2f}", f"{float(p.get('age_max_s', 0.0)):.0f}"]
            for p in per]
    flagged = [float(p.get("age_max_s", 0.0)) > STALE_FLAG_S for p in per]
    headers = ("aMussel", "battery error % (mean)", "battery error % (max)", "oldest knowledge s")
    return f"<p>{html.escape(said)}.</p>\n" + table(headers, rows, CAPTION, flagged=flagged)
