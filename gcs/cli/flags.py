"""argparse types for the flags of every `vil` command: a bad value is argparse's one error line
naming the flag, exit 2, before anything starts.

Numbers go through `scenario.out_of_range`, the one finite-and-in-range check that scenario files
use too. Output paths are probed (a file created and removed) because permissions alone do not say
whether a path can be written (root, /proc, read-only mounts).
"""

from __future__ import annotations

import argparse
import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

from gcs.mission.platform import Platform, platform_of
from gcs.scenario.reader import MAX_DURATION_S, out_of_range
from missiontime.durations import parse_duration_s

N = TypeVar("N", int, float)


def _checked(text: str, convert: Callable[[str], N], what: str, lo: float | None, hi: float | None) -> N:
    try:
        value = convert(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from None
    problem = out_of_range(value, lo, hi)
    if problem:
        raise argparse.ArgumentTypeError(problem)
    return value


def number(text: str, lo: float | None = None, hi: float | None = None) -> float:
    return _checked(text, float, "a number", lo, hi)


def number_in(lo: float | None, hi: float | None) -> Callable[[str], float]:
    return lambda text: number(text, lo, hi)


def integer_in(lo: int, hi: int) -> Callable[[str], int]:
    return lambda text: _checked(text, int, "an integer", lo, hi)


def fraction(text: str) -> float:
    value = number(text, 0.0, 1.0)
    if value >= 1.0:
        raise argparse.ArgumentTypeError(f"must be a fraction below 1, got {text}")
    return value


def duration(text: str) -> float:
    """A length of mission time with its unit ("90s", "40min", "1h"), up to a week."""
    return _seconds(text, MAX_DURATION_S, allow_zero=False)


def duration_up_to(max_s: float) -> Callable[[str], float]:
    """A length of time with its unit ("0.2s", "200ms"), 0 to `max_s` seconds."""
    return lambda text: _seconds(text, max_s, allow_zero=True)


def mission_time(text: str) -> float:
    """A moment of the mission, as the time since its start with a unit ("90s", "12min"), up to 90 days."""
    return _seconds(text, MAX_DURATION_S, allow_zero=True)


def _seconds(text: str, max_s: float, allow_zero: bool) -> float:
    try:
        return parse_duration_s(text, max_s, allow_zero=allow_zero)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def platform(text: str) -> Platform:
    """lockstep or event (`gcs.mission.platform`)."""
    try:
        return platform_of(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def window(text: str) -> tuple[float, float]:
    """START:END, two mission times with their units ("92s:112s"), START < END."""
    start, sep, end = text.partition(":")
    if not sep:
        raise argparse.ArgumentTypeError(f"expected START:END with units, e.g. 92s:112s, got {text!r}")
    try:
        span = (mission_time(start), mission_time(end))
    except argparse.ArgumentTypeError as exc:
        raise argparse.ArgumentTypeError(f"START:END {text}: {exc}") from None
    if not span[0] < span[1]:
        raise argparse.ArgumentTypeError(f"expected START:END with START before END, got {text!r}")
    return span


def apad_at(text: str) -> tuple[int, float]:
    """SYSID:T: an aPad system id (1..249) and a mission time with its unit ("3:10min")."""
    sysid, sep, at = text.partition(":")
    if not sep or not sysid.isdigit() or not 1 <= int(sysid) <= 249:
        raise argparse.ArgumentTypeError(f"expected SYSID:T with 1 <= SYSID <= 249, e.g. 3:600s, got {text!r}")
    try:
        return int(sysid), mission_time(at)
    except argparse.ArgumentTypeError as exc:
        raise argparse.ArgumentTypeError(f"SYSID:T {text}: {exc}") from None


def writable_file(text: str) -> Path:
    """A file we can write (created if new): checked now, not after a whole run."""
    path = Path(text)
    if path.is_dir():
        raise argparse.ArgumentTypeError(f"{path} is a folder, not a file")
    try:
        if path.exists():
            with path.open("ab"):
                pass
        else:
            with path.open("xb"):
                pass
            path.unlink()
    except OSError as exc:
        raise argparse.ArgumentTypeError(f"cannot write {path}: {exc.strerror or exc}") from None
    return path


def writable_dir(text: str) -> Path:
    """A folder we can create and write in; nothing is left behind by the check."""
    path = Path(text)
    existing = path
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if not existing.is_dir():
        raise argparse.ArgumentTypeError(f"{existing} is not a folder")
    try:
        os.rmdir(tempfile.mkdtemp(prefix=".vil-probe-", dir=existing))
    except OSError as exc:
        raise argparse.ArgumentTypeError(f"cannot write in {existing}: {exc.strerror or exc}") from None
    return path
