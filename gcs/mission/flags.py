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

from gcs.mission.scenario import MAX_DURATION_S, out_of_range, parse_duration_s

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
    try:
        return parse_duration_s(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def window(text: str) -> tuple[float, float]:
    """START:END in mission seconds, 0 <= START < END <= a week."""
    start, sep, end = text.partition(":")
    try:
        span = (float(start), float(end))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected START:END in mission seconds, got {text!r}") from None
    if not sep or any(out_of_range(t, 0.0, MAX_DURATION_S) for t in span) or not span[0] < span[1]:
        raise argparse.ArgumentTypeError(
            f"expected START:END with 0 <= START < END <= {MAX_DURATION_S:.0f}, got {text!r}")
    return span


def apad_at(text: str) -> tuple[int, float]:
    """SYSID:T: an aPad system id (1..249) and a mission time in seconds (0 <= T <= a week)."""
    sysid, sep, at = text.partition(":")
    try:
        pair = (int(sysid), float(at))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected SYSID:T (an aPad id, mission seconds), got {text!r}") from None
    if not sep or not 1 <= pair[0] <= 249 or out_of_range(pair[1], 0.0, MAX_DURATION_S):
        raise argparse.ArgumentTypeError(
            f"expected SYSID:T with 1 <= SYSID <= 249 and 0 <= T <= {MAX_DURATION_S:.0f}, got {text!r}")
    return pair


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
