"""Whether `vil.sweep` is called from a script's top level outside `if __name__ == "__main__":`.

A local Dask cluster starts its workers as spawned processes (distributed's multiprocessing method),
and a spawned process imports the parent's main script again: unguarded, the call runs again in each
worker, which tries to start a cluster of its own while still starting, and Dask prints a traceback
per worker ("Nanny failed to start"). Found before any process starts, it is one line instead.
"""

from __future__ import annotations

import ast
import inspect
import sys
from pathlib import Path

import dask

ADVICE = ('vil.sweep starts worker processes that import this script again: call it under '
          'if __name__ == "__main__": (line {line} of {file} runs it at the top level)')


def unguarded_call() -> tuple[str, int] | None:
    """(script, line) of the main script's top-level statement that is calling, when that statement is
    outside an `if __name__ == "__main__":` block and workers are spawned; None otherwise (a notebook, an
    interactive session, `python -c`, a package's `__main__`, a guarded call, workers forked)."""
    if dask.config.get("distributed.worker.multiprocessing-method", "spawn") == "fork":
        return None
    main = sys.modules.get("__main__")
    spec_name = getattr(getattr(main, "__spec__", None), "name", "") or ""
    if spec_name == "__main__" or spec_name.endswith(".__main__"):
        return None  # `python -m pkg`: spawn does not run a package's __main__ again (multiprocessing.spawn)
    script = getattr(main, "__file__", None)
    frame = inspect.currentframe()
    while frame is not None and not (frame.f_code.co_name == "<module>"
                                     and frame.f_globals.get("__name__") == "__main__"):
        frame = frame.f_back
    if script is None or frame is None or not script.endswith(".py"):
        return None
    line = frame.f_lineno
    try:
        tree = ast.parse(Path(script).read_text(encoding="utf-8"))
    except (OSError, SyntaxError, UnicodeDecodeError, ValueError):
        return None  # nothing to read: let Dask say what it says
    guarded = any(isinstance(node, ast.If) and _is_main_test(node.test)
                  and node.lineno <= line <= (node.end_lineno or node.lineno) for node in tree.body)
    return None if guarded else (script, line)


def _is_main_test(test: ast.expr) -> bool:
    """`__name__ == "__main__"` (either way round)."""
    if not (isinstance(test, ast.Compare) and len(test.ops) == 1 and isinstance(test.ops[0], ast.Eq)):
        return False
    return {ast.unparse(test.left), ast.unparse(test.comparators[0])} == {"__name__", "'__main__'"}
