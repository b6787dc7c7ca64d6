"""The console's colours: explicit hex (named red and magenta look alike in exports, NOTES.md)."""

from __future__ import annotations

from gcs.view.snapshot import MarkerColour, Snapshot

GREEN, RED, GREY, PURPLE = "#22c55e", "#ef4444", "#9ca3af", "#c026d3"
OUTLINE, APAD, TRACE, AXIS, BLUE = "#64748b", "#facc15", "#38bdf8", "#94a3b8", "#60a5fa"
GRID, LABEL = "#475569", "#f8fafc"
MARKER_COLOURS = {MarkerColour.CHARGED: GREEN, MarkerColour.CANDIDATE: RED,
                  MarkerColour.DEPLETED: GREY, MarkerColour.DOCKED: PURPLE}
# A swarm's aPads, in the scenario's order (the first is the one aPad's colour); none is a marker's.
APAD_COLOURS = [APAD, "#fb923c", "#2dd4bf", "#f472b6", "#a3e635", "#e2e8f0", "#818cf8", "#fda4af", "#0ea5e9"]
PALETTE = [AXIS, GREEN, RED, GREY, PURPLE, OUTLINE, APAD, TRACE, BLUE, GRID, LABEL, *APAD_COLOURS[1:]]
MARKER_INDEX = {k: PALETTE.index(v) for k, v in MARKER_COLOURS.items()}
_CLASSES = (f"[{GREEN}]●[/] charged  [{RED}]●[/] pool  [{PURPLE}]●[/] docked  [{GREY}]●[/] depleted  ")
LEGEND = _CLASSES + f"[{APAD}]◆[/][{PURPLE}]●[/][{OUTLINE}]○[/] aPad, slots"
SWARM_LEGEND = _CLASSES + f"2: aPad 2's  [{APAD}]◆[/][{APAD_COLOURS[1]}]◆[/] aPads"


def apad_colour(snap: Snapshot, sysid: int) -> str:
    """An aPad's own colour: by its place in the scenario."""
    place = next((i for i, a in enumerate(snap.apads) if a.system_id == sysid), 0)
    return APAD_COLOURS[place % len(APAD_COLOURS)]
