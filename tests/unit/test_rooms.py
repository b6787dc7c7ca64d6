"""The house's plan held to its code (docs/architecture.md, "The rooms"): the import graph of gcs/ read from
the source, as text, every import statement counted (those under TYPE_CHECKING too: a reader follows them).

No circle of files; the folders of gcs/ in one order, none importing a folder above it; inside a folder the
longest chain of imports at most `MAX_CHAIN` files; no folder over `MAX_FOLDER_LINES` lines. And the seams the
loop's refactoring cut (issue 36): phases and turns reach nothing but their crew, and the run-building line
stands once."""

from __future__ import annotations

import ast
import functools
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
GCS = ROOT / "gcs"
MAX_CHAIN = 8
MAX_FOLDER_LINES = 4000
# The folders of gcs/, lowest first: each may import those before it (and the packages outside gcs/).
LAYERS = ("link", "strategies", "results", "scenario", "view", "records", "acoustic_net", "swarm", "belief",
          "loop", "mission", "report", "console", "sweep", "tune", "cli")


def module_of(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


@functools.cache
def graph() -> dict[str, set[str]]:
    """Each module of gcs/ -> the modules of gcs/ it imports (a `from package import name` that names a
    module counts as that module)."""
    modules = {module_of(p): p for p in GCS.rglob("*.py")}
    edges: dict[str, set[str]] = {}
    for name, path in modules.items():
        out: set[str] = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                out |= {a.name for a in node.names if a.name in modules}
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                subs = {f"{node.module}.{a.name}" for a in node.names} & modules.keys()
                out |= subs or ({node.module} & modules.keys())
        edges[name] = out - {name}
    return edges


def files(edges: dict[str, set[str]]) -> dict[str, set[str]]:
    """Without the packages' faces (an __init__ only hands names on)."""
    faces = {m for m in edges if (GCS.parent / (m.replace(".", "/") + "/__init__.py")).is_file()}
    return {m: {t for t in ts if t not in faces} for m, ts in edges.items() if m not in faces}


def folder(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 2 else ""


def test_no_circle_of_files() -> None:
    edges = files(graph())
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(m: str) -> None:
        state[m] = 1
        stack.append(m)
        for t in sorted(edges.get(m, ())):
            assert state.get(t) != 1, "a circle: " + " -> ".join([*stack[stack.index(t):], t])
            if t not in state:
                visit(t)
        stack.pop()
        state[m] = 2

    for m in sorted(edges):
        if m not in state:
            visit(m)


def test_every_folder_imports_only_the_folders_below_it() -> None:
    assert {p.name for p in GCS.iterdir() if p.is_dir() and (p / "__init__.py").is_file()} == set(LAYERS)
    up = sorted((m, t) for m, ts in graph().items() for t in ts
                if folder(m) and folder(t) and LAYERS.index(folder(t)) > LAYERS.index(folder(m)))
    assert not up, f"imports running back up: {up}"


def test_the_longest_chain_inside_a_folder_is_at_most_eight_files() -> None:
    edges = files(graph())

    @functools.cache
    def chain(m: str) -> tuple[str, ...]:
        inside = [chain(t) for t in edges[m] if folder(t) == folder(m)]
        return (m, *max(inside, key=len, default=()))

    longest = max((chain(m) for m in edges if folder(m)), key=len)
    assert len(longest) <= MAX_CHAIN, " -> ".join(longest)


def test_no_folder_of_gcs_is_over_four_thousand_lines() -> None:
    for name in LAYERS:
        lines = sum(len(p.read_text(encoding="utf-8").splitlines()) for p in (GCS / name).rglob("*.py"))
        assert lines <= MAX_FOLDER_LINES, f"gcs/{name}: {lines} lines"


def test_phases_and_turns_reach_nothing_but_their_crew() -> None:
    for name in ("phases", "turns", "home_charge", "sleep_orders", "trip_energy"):
        tree = ast.parse((GCS / "loop" / f"{name}.py").read_text(encoding="utf-8"))
        reach = [node.lineno for node in ast.walk(tree) if isinstance(node, ast.Attribute) and node.attr == "api"]
        assert not reach, f"gcs/loop/{name}.py reaches the API at lines {reach}"


def test_the_run_building_line_stands_once() -> None:
    sources = [p for d in ("gcs", "vil") for p in (ROOT / d).rglob("*.py")]
    found = [p for p in sources if "start_config=None" in p.read_text(encoding="utf-8")]
    assert [p.relative_to(ROOT).as_posix() for p in found] == ["gcs/mission/start.py"]
