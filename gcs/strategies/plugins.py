"""Strategies from outside the package: a file, a module, or an installed entry point.

Wherever a strategy is named (`vil run --strategy`, `vil gcs`, a scenario's
`mission.collect_strategy`, a sweep's `strategies`), the name may also be

    path/to/mine.py:slack_first      a function in a file (a scenario's path: from the scenario's folder)
    mypkg.strategies:slack_first     a function in an importable module
    slack_first                      an entry point of the `vil.strategies` group (a pip-installed package)

`load_strategy` loads it once, checks its signature (`(PlanInput, CostWeights) -> Plan`, the shipped
ones'), registers it under the function's (or the entry point's) name, and returns that name, which
results, tables and run folders show. `source_of(name)` is what another process needs to load it
again (a `vil run --jobs` worker, a Dask worker, a resumed run). A function may carry its `Traits`
as an attribute `traits`.
"""

from __future__ import annotations

import difflib
import hashlib
import importlib
import importlib.metadata
import importlib.util
import inspect
import sys
from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import Any

from gcs.strategies.base import COLLECT, STRATEGIES, TRAITS, Strategy, StrategyError, Traits, first_line

ENTRY_POINT_GROUP = "vil.strategies"
SOURCES: dict[str, str] = {}  # a loaded strategy's name -> the spec that loads it again (absolute for files)


def load_strategy(spec: str, base: Path | None = None) -> str:
    """The registered name of the strategy `spec` names (see the module's docstring), loading and
    registering it first if it is not yet; a file path is taken from `base` (default: the working
    directory). `StrategyError` naming what is wrong."""
    spec = spec.strip()
    if spec in STRATEGIES:
        return spec
    if ":" not in spec:
        return _from_entry_point(spec)
    where, _, function = spec.rpartition(":")
    if not where or not function.isidentifier():
        raise StrategyError(f"{spec!r}: expected FILE.py:FUNCTION or MODULE:FUNCTION")
    if "/" in where and not where.endswith(".py"):
        raise StrategyError(f"{spec!r}: a strategy file is a .py file (FILE.py:FUNCTION)")
    if where.endswith(".py"):
        path = ((base or Path.cwd()) / where).resolve()
        module, source = _file_module(path), f"{path}:{function}"
    else:
        module, source = _import(where, spec), spec
    fn = getattr(module, function, None)
    if fn is None:
        raise StrategyError(f"{spec}: no function {function!r} in {where}")
    return _register(function, fn, source, spec)


def is_plugin(name: str) -> bool:
    """Whether `name` was loaded from outside the package (a file, a module, an entry point)."""
    return name in SOURCES


def fingerprint(name: str) -> str:
    """A digest of a loaded strategy's source file ("" for a shipped one, or one without a file): a
    sweep's cell key includes it, so an edited strategy file makes new cells."""
    if not is_plugin(name):
        return ""
    try:
        path = inspect.getsourcefile(STRATEGIES[name])
        return hashlib.sha256(Path(path).read_bytes()).hexdigest()[:16] if path else ""
    except (OSError, TypeError):
        return ""


def source_of(name: str) -> str:
    """What loads `name` again in another process: its spec for a loaded strategy, else the name."""
    return SOURCES.get(name, name)


def shipped_names() -> tuple[str, ...]:
    """The shipped collection strategies, in `COLLECT`'s order (a sweep's "all")."""
    return tuple(str(s) for s in COLLECT if s in STRATEGIES)


def strategy_names() -> tuple[str, ...]:
    """Every strategy a run may name now: the shipped ones, then those loaded."""
    return (*shipped_names(), *(name for name in STRATEGIES if is_plugin(name)))


def _register(name: str, fn: Any, source: str, spec: str) -> str:
    if not callable(fn):
        raise StrategyError(f"{spec}: {name} is not a function")
    try:
        inspect.signature(fn).bind(None, None)
    except TypeError:
        raise StrategyError(f"{spec}: {name} must take two arguments, (PlanInput, CostWeights), "
                            "as the shipped strategies do") from None
    except ValueError:  # a builtin without a signature: let the first plan tell
        pass
    known = STRATEGIES.get(name)
    if known is not None and known is not fn and SOURCES.get(name) != source:
        raise StrategyError(f"{spec}: the name {name!r} is taken by {SOURCES.get(name, 'a shipped strategy')}; "
                            "rename the function")
    traits = getattr(fn, "traits", Traits())
    if not isinstance(traits, Traits):
        raise StrategyError(f"{spec}: {name}.traits is {traits!r}, not a gcs.strategies.Traits")
    strategy: Strategy = fn
    STRATEGIES[name], TRAITS[name], SOURCES[name] = strategy, traits, source
    return name


def _file_module(path: Path) -> ModuleType:
    """The module of a strategy file, loaded once per path (a Dask worker elsewhere gets the file as a
    module instead: `gcs.sweep.cluster.ship_strategies`)."""
    if not path.is_file():
        raise StrategyError(f"{path}: no such strategy file")
    name = f"vil_strategy_{path.stem}_{hashlib.sha1(str(path).encode()).hexdigest()[:8]}"
    if name in sys.modules:
        return sys.modules[name]
    found = importlib.util.spec_from_file_location(name, path)
    if found is None or found.loader is None:
        raise StrategyError(f"{path}: not a Python file")
    module = importlib.util.module_from_spec(found)
    sys.modules[name] = module
    try:
        found.loader.exec_module(module)
    except Exception as exc:  # the user's file: whatever it raises is one line about it
        del sys.modules[name]
        raise StrategyError(f"{path}: importing it failed: {first_line(exc)}") from None
    return module


def _import(module: str, spec: str) -> ModuleType:
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise StrategyError(f"{spec}: cannot import {module}: {first_line(exc)}") from None
    except Exception as exc:  # the user's module raised while importing
        raise StrategyError(f"{spec}: importing {module} failed: {first_line(exc)}") from None


def _from_entry_point(name: str) -> str:
    points = {ep.name: ep for ep in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP)}
    if name not in points:
        known = [*STRATEGIES, *points]
        close = difflib.get_close_matches(name, known, n=1)
        hint = f"; did you mean {close[0]}?" if close else ""
        raise StrategyError(f"unknown strategy {name!r}{hint} (shipped: {', '.join(STRATEGIES)}; or FILE.py:FUNCTION, "
                            f"MODULE:FUNCTION, a package's {ENTRY_POINT_GROUP} entry point)")
    point = points[name]
    try:
        fn: Callable[..., object] = point.load()
    except Exception as exc:  # an installed package that fails to import
        raise StrategyError(f"{name}: loading entry point {point.value} failed: {first_line(exc)}") from None
    return _register(name, fn, name, f"{name} ({point.value})")
