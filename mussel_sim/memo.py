"""What was made from the last objects asked about, made again only for other objects (by identity).

The lockstep loop asks the same questions of the same objects again and again: the fleet's state
arrays are read-only and passed on unchanged by most steps, parameters are swapped whole when they
change, a quiet step's inputs are the last ones again. So the answer for the last objects is kept
with the objects themselves (while held, their ids cannot be another's). The last answer is read
once per call: fleets of a sweep run as threads may share a module's memo.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Generic, TypeVar

T = TypeVar("T")


class LastMade(Generic[T]):
    """`make(*keys)`, kept for the keys of the last call."""

    __slots__ = ("_last", "_make")

    def __init__(self, make: Callable[..., T]) -> None:
        self._make = make
        self._last: tuple[tuple[object, ...], T] | None = None

    def __call__(self, *keys: object) -> T:
        last = self._last
        if last is not None and len(last[0]) == len(keys):
            for held, key in zip(last[0], keys, strict=True):  # a loop: a generator frame cost more than the look
                if held is not key:
                    break
            else:
                return last[1]
        value = self._make(*keys)
        self._last = (keys, value)
        return value
