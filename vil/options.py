"""`vil.run`'s keyword arguments as the `RunOptions` `vil run`'s flags make: the same values written
the Python way (a number of seconds or a string with its unit, tuples or the flags' own strings).
Bad values raise `ValueError` with one line naming the argument (`vil.Error` at the call)."""

from __future__ import annotations

import argparse
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import TypeVar

from gcs.cli import flags
from gcs.mission.platform import Platform, platform_of
from gcs.mission.start import MAX_DELAY_S, RUNS, RunOptions
from gcs.scenario.fields import out_of_range
from gcs.strategies import load_strategy
from mavlink_dialect.signing import key_from_passphrase, load_key
from missiontime.durations import MAX_MISSION_S, parse_duration_s

Seconds = str | float  # "200ms", "40min", or a number of seconds
Window = str | tuple[Seconds, Seconds]  # "92s:112s" or (92, 112)
ApadAt = str | tuple[int, Seconds]  # "3:10min" or (3, 600)
T = TypeVar("T")


def run_options(
    *, strategy: str | None, seed: int | None, duration: Seconds | None, theta: float | None, draw_fleet: bool,
    loss: float, latency: Seconds, jitter: Seconds, duplicate: float, outages: Iterable[Window],
    fail_apads: Iterable[ApadAt], proxy: bool, signing_key: str | Path | None, resume: bool, out: str | Path | None,
    platform: str = "lockstep",
) -> RunOptions:
    """The options of one run. `signing_key`: a passphrase (str) or a key file (Path); None: as `vil run`,
    $VIL_SIGNING_KEY if set. `ScenarioError`, `StrategyError`, `SigningKeyError` or `ValueError`: one line."""
    return RunOptions(
        strategy=None if strategy is None else load_strategy(strategy),
        seed=_integer("seed", seed), duration_s=None if duration is None else seconds("duration", duration),
        theta=None if theta is None else _number("theta", theta), draw_fleet=bool(draw_fleet),
        loss_frac=_number("loss", loss), duplicate_frac=_number("duplicate", duplicate),
        latency_s=seconds("latency", latency, MAX_DELAY_S, allow_zero=True),
        jitter_s=seconds("jitter", jitter, MAX_DELAY_S, allow_zero=True),
        outages_s=tuple(_window(w) for w in outages), fail_apads=tuple(_apad_at(a) for a in fail_apads),
        proxy=bool(proxy), signing_key=key_from_passphrase(signing_key) if isinstance(signing_key, str)
        else load_key(signing_key), resume=bool(resume), out=RUNS if out is None else Path(out),
        platform=_platform(platform),
    )


def _platform(value: object) -> Platform:
    if not isinstance(value, str):
        raise ValueError(f"platform: expected \"lockstep\" or \"event\", got {value!r}")
    try:
        return platform_of(value)
    except ValueError as exc:
        raise ValueError(f"platform: {exc}") from None


def seconds(name: str, value: Seconds, max_s: float = MAX_MISSION_S, allow_zero: bool = False) -> float:
    """A length of time: a number of seconds, or a string with its unit ("200ms", "40min")."""
    if isinstance(value, int | float) and not isinstance(value, bool):
        why = out_of_range(float(value), 0.0, max_s) or (None if value or allow_zero else "must be more than 0 s")
        if why:
            raise ValueError(f"{name}: {why}")
        return float(value)
    try:
        return parse_duration_s(value, max_s, allow_zero=allow_zero)
    except ValueError as exc:
        raise ValueError(f"{name}: {exc}") from None


def _number(name: str, value: object) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ValueError(f"{name}: expected a number, got {value!r}")
    return float(value)


def _integer(name: str, value: object) -> int | None:
    if value is not None and (isinstance(value, bool) or not isinstance(value, int)):
        raise ValueError(f"{name}: expected an integer, got {value!r}")
    return value


def _window(value: Window) -> tuple[float, float]:
    if isinstance(value, str):
        return _flag("outages", flags.window, value)
    if not isinstance(value, tuple | list) or len(value) != 2:
        raise ValueError(f'outages: expected "START:END" or (start, end), got {value!r}')
    return seconds("outages", value[0], allow_zero=True), seconds("outages", value[1], allow_zero=True)


def _apad_at(value: ApadAt) -> tuple[int, float]:
    if isinstance(value, str):
        return _flag("fail_apads", flags.apad_at, value)
    if not isinstance(value, tuple | list) or len(value) != 2:
        raise ValueError(f'fail_apads: expected "SYSID:T" or (sysid, t), got {value!r}')
    sysid = value[0]
    if isinstance(sysid, bool) or not isinstance(sysid, int):
        raise ValueError(f"fail_apads: expected an aPad system id, got {sysid!r}")
    return sysid, seconds("fail_apads", value[1], allow_zero=True)


def _flag(name: str, parse: Callable[[str], T], text: str) -> T:
    try:
        return parse(text)
    except argparse.ArgumentTypeError as exc:
        raise ValueError(f"{name}: {exc}") from None
