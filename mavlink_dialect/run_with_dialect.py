"""Run a pymavlink or MAVProxy tool with the subCULTron dialect available as `--dialect subcultron`.

    python -m mavlink_dialect.run_with_dialect mavproxy.py --dialect subcultron --mav20 \\
        --master=udpin:127.0.0.1:14550
    python -m mavlink_dialect.run_with_dialect mavlogdump.py --dialect subcultron runs/sitl/apad1.tlog

pymavlink's `mavutil.set_dialect(NAME)` only imports `pymavlink.dialects.v20.NAME` (and only
picks v20 if MAVLINK20 is set before mavutil is imported); our generated module lives in this
package, not in site-packages. This launcher registers `mavlink_dialect.subcultron` under that
name in `sys.modules`, sets MAVLINK20=1 (and MAVLINK_DIALECT=subcultron unless already set, so
tools without a --dialect option decode our messages too), then runs the named console script
in this interpreter with `runpy`, as if it had been started itself. Nothing is written anywhere.

The tool still needs its own `--dialect subcultron` where it has one (mavproxy.py, mavlogdump.py,
mavlink_connection(..., dialect=...)): the launcher makes the name importable, it does not force it.
A script is looked up as given (a path), then beside this Python interpreter (the venv's bin/),
then on PATH.
"""

from __future__ import annotations

import os
import runpy
import shutil
import sys
from pathlib import Path

DIALECT = "subcultron"
PYMAVLINK_PACKAGE = "pymavlink.dialects.v20"


def register() -> None:
    """Make `pymavlink.dialects.v20.subcultron` importable for mavutil. Idempotent."""
    os.environ["MAVLINK20"] = "1"
    os.environ.setdefault("MAVLINK_DIALECT", DIALECT)
    import importlib

    from mavlink_dialect import subcultron

    package = importlib.import_module(PYMAVLINK_PACKAGE)
    sys.modules[f"{PYMAVLINK_PACKAGE}.{DIALECT}"] = subcultron
    # `__import__` returns the top package and mavutil walks the attributes down to the module.
    setattr(package, DIALECT, subcultron)


def find_script(name: str) -> Path | None:
    """The console script `name`: a path as given, else beside this interpreter, else on PATH."""
    given = Path(name)
    if given.is_file():
        return given
    if given.name != name:
        return None  # a path that does not exist: do not guess
    beside = Path(sys.executable).parent / name  # not resolved: a venv's python is a symlink
    if beside.is_file():
        return beside
    found = shutil.which(name)
    return Path(found) if found else None


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else list(argv)
    if not args or args[0] in ("-h", "--help"):
        print(__doc__.strip())
        return 0 if args else 2
    script = find_script(args[0])
    if script is None:
        print(f"run_with_dialect: no script {args[0]!r} (not a file, not beside {sys.executable}, not on PATH)",
              file=sys.stderr)
        return 2
    register()
    sys.argv = [str(script), *args[1:]]
    sys.path.insert(0, str(script.resolve().parent))  # what `python SCRIPT` would do
    try:
        runpy.run_path(str(script), run_name="__main__")
    except BrokenPipeError:
        # `mavlogdump.py ... | head`: the reader left. Stop quietly, as a shell tool does (the
        # Python docs' recipe: point stdout at devnull so the interpreter's final flush cannot fail).
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except SystemExit as exc:
        code = exc.code
        if code is None:
            return 0
        if isinstance(code, int):
            return code
        print(code, file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
