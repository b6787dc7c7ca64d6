"""Durations as people write them, always with their unit: "90s", "40min", "1.5h", "7d", "200ms".

A bare number is refused: `--duration 40` could be seconds or minutes, and guessing wrong runs a
mission sixty times too short or too long. The one parser for every flag and scenario field that
takes a length of time ("m" is read as minutes too, as the shipped scenarios write "40m").
"""

from __future__ import annotations

import math
import re

MAX_MISSION_S = 90 * 86400.0  # a season at sea; longer is a typo (a week of pool12 is ~40 min of CPU)
UNIT_S = {"ms": 1e-3, "s": 1.0, "m": 60.0, "min": 60.0, "h": 3600.0, "d": 86400.0}  # d: long missions
_DURATION = re.compile(r"^\s*(\d+(?:\.\d*)?|\.\d+)\s*([a-z]*)\s*$")


def parse_duration_s(text: object, max_s: float = MAX_MISSION_S, allow_zero: bool = False) -> float:
    """Seconds from "90s", "40min", "40m", "1.5h" or "200ms", in (0, max_s] ([0, max_s] with
    `allow_zero`); ValueError with one line saying what to write instead."""
    if isinstance(text, int | float) and not isinstance(text, bool) and math.isfinite(text):
        n = f"{text:g}"  # a number in a scenario file: the unit goes in a string
        raise ValueError(f'{n} has no unit: say "{n}s", "{n}min" or "{n}h"')
    if not isinstance(text, str):
        raise ValueError(f"{text!r} is not a duration: say e.g. \"90s\", \"40min\" or \"1.5h\"")
    if text.strip().startswith("-"):
        raise ValueError(f"{text.strip()} is not a positive duration")
    match = _DURATION.match(text)
    if match is not None and match.group(2) == "":
        n = text.strip()
        raise ValueError(f"{n} has no unit: say {n}s, {n}min or {n}h")
    if match is None or match.group(2) not in UNIT_S:
        raise ValueError(f"{text!r} is not a duration: say e.g. 90s, 40min or 1.5h")
    seconds = float(match.group(1)) * UNIT_S[match.group(2)]
    if not math.isfinite(seconds) or seconds < 0 or (seconds == 0 and not allow_zero):
        raise ValueError(f"{text.strip()} is not a positive duration")
    if seconds > max_s:
        raise ValueError(f"{text.strip()} is more than {describe_s(max_s)}")
    return seconds


def describe_s(seconds: float) -> str:
    """A limit in words: "90 days", "5 s"."""
    return "90 days" if seconds == MAX_MISSION_S else f"{seconds:g} s"


def hms(t_s: float) -> str:
    """Mission time that reads at any length (whole seconds): minutes:seconds under an hour (the console's
    12:30), hours:minutes:seconds under a day (2:52:00, never 172:00), then days and hours (8 d 0 h)."""
    t = max(int(t_s), 0)
    if t < 3600:
        return f"{t // 60:02d}:{t % 60:02d}"
    if t < 86400:
        return f"{t // 3600}:{t % 3600 // 60:02d}:{t % 60:02d}"
    return f"{t // 86400} d {t % 86400 // 3600} h"
