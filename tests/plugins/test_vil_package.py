"""`vil` in Python (issue 22): the same figures as `vil run`, the example notebook executed from top
to bottom by a real Jupyter kernel, and bad input as `vil.Error`."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

import vil
from gcs.records.run_folder import RunFolder

ROOT = Path(__file__).resolve().parents[2]
NOTEBOOK = ROOT / "docs" / "examples" / "vil-notebook.ipynb"

pytestmark = [pytest.mark.sitl]


def test_vil_run_gives_the_figures_vil_run_prints_for_the_same_scenario_strategy_and_seed(tmp_path: Path) -> None:
    r = vil.run("pool12", strategy="greedy", seed=2, duration="15m", out=tmp_path / "api")
    done = subprocess.run([sys.executable, "-m", "gcs.cli", "run", "pool12", "--strategy", "greedy", "--seed", "2",
                           "--duration", "15m", "--out", str(tmp_path / "cli"), "--json", str(tmp_path / "cli.json")],
                          capture_output=True, text=True, timeout=300, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert done.returncode == 0, done.stderr
    cli = json.loads((tmp_path / "cli.json").read_text())
    up = cli["uptime"]
    assert (r.uptime_avg, r.uptime_min, r.uptime_max) == (up["avg"], up["min"], up["max"])
    assert (r.cost_m, r.active_avg, r.cycles, r.strategy, r.seed) == (cli["cost_m"], cli["active_avg"], cli["cycles"],
                                                                     "greedy", 2)
    assert r.cost_m > 0 and r.folder.name == "pool12-greedy-seed2-run1"
    assert list(r.mussels.index) == sorted(m["id"] for m in cli["mussels"])
    assert r.mussels["uptime_pct"].tolist() == [m["uptime_pct"] for m in sorted(cli["mussels"], key=lambda m: m["id"])]
    assert r.active["t_s"].iloc[-1] == pytest.approx(900.0, abs=1.0) and r.active["active"].max() <= 12
    assert vil.load(tmp_path / "api" / "latest").raw == r.raw


def test_bad_input_is_a_vil_error_of_one_line(tmp_path: Path) -> None:
    for call, words in ((lambda: vil.scenario("pool12", fields={"mission.thetta": 60}),
                         "mission.thetta: unknown field (did you mean mission.theta?)"),
                        (lambda: vil.scenario("pool12", fields={"misson.theta": 60}), "(did you mean mission?)"),
                        (lambda: vil.scenario("Pool12"), "did you mean pool12?"),
                        (lambda: vil.scenario("nowhere"), "no such scenario"),
                        (lambda: vil.run("pool12", strategy="cautios", out=tmp_path), "did you mean cautious?"),
                        (lambda: vil.run("pool12", duration="forever", out=tmp_path), "forever"),
                        (lambda: vil.load(tmp_path), "no result.json")):
        with pytest.raises(vil.Error) as caught:
            call()
        assert words in str(caught.value) and "\n" not in str(caught.value), str(caught.value)
    assert not list(tmp_path.iterdir())  # nothing started


# The default run's variant of the notebook: its missions shorter (the runs 5 of their 20 minutes, the sweep's
# 2 of its 10), the same cells and calls; the long run (pytest -m long) runs it as written.
SHORTER = {'duration="20m"': 'duration="5m"', 'mission.duration = "10m"': 'mission.duration = "2m"'}


def test_the_example_notebook_runs_from_top_to_bottom(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    _run_notebook(tmp_path, monkeypatch, SHORTER)


@pytest.mark.long
def test_the_example_notebook_as_written(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    _run_notebook(tmp_path, monkeypatch, {})


def _run_notebook(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, replaced: dict[str, str]) -> None:
    notebook = nbformat.read(NOTEBOOK, as_version=4)
    sources = [cell.source for cell in notebook.cells if cell.cell_type == "code"]
    for old, new in replaced.items():
        assert any(old in source for source in sources), f"the notebook no longer says {old}"
        for cell in notebook.cells:
            cell.source = cell.source.replace(old, new)
    client = NotebookClient(notebook, timeout=600, kernel_name="python3",
                            resources={"metadata": {"path": str(tmp_path)}})
    monkeypatch.setenv("PYTHONPATH", str(ROOT))  # the kernel is a process of its own
    client.execute()  # raises CellExecutionError, with the cell and its traceback, if any cell fails
    outputs = [o for cell in notebook.cells if cell.cell_type == "code" for o in cell.get("outputs", [])]
    text = "".join(str(o.get("text", "")) + str(o.get("data", {}).get("text/plain", "")) for o in outputs)
    assert "uptime" in text and "mission.thetta: unknown field" in text
    assert any("image/png" in o.get("data", {}) for o in outputs)  # the active-count figure
    assert (tmp_path / "sweeps" / "small" / "results.parquet").is_file()


SMALL = '[sweep]\nscenarios = ["pool12"]\nstrategies = ["none"]\nseeds = [1]\n[set]\nmission.duration = "1m"\n'


def _script(folder: Path, body: str) -> subprocess.CompletedProcess[str]:
    (folder / "script.py").write_text(body)
    return subprocess.run([sys.executable, "script.py"], cwd=folder, capture_output=True, text=True, timeout=120,
                          env={**os.environ, "PYTHONPATH": str(ROOT)})


def test_vil_sweep_at_a_scripts_top_level_is_one_line_saying_to_guard_it(tmp_path: Path) -> None:
    """Unguarded, each spawned worker imports the script again and runs the sweep again: four Dask tracebacks
    ("Nanny failed to start") before; now `vil.Error` with the advice, before any process starts."""
    (tmp_path / "small.toml").write_text(SMALL)
    done = _script(tmp_path, 'import vil\n\nrows = vil.sweep("small.toml", out="sw", workers=2)\n')
    assert done.returncode == 1 and "Nanny" not in done.stderr and "RuntimeError" not in done.stderr
    assert done.stderr.splitlines()[-1] == (
        'vil.api.Error: vil.sweep starts worker processes that import this script again: call it under '
        f'if __name__ == "__main__": (line 3 of {tmp_path / "script.py"} runs it at the top level)')
    assert not (tmp_path / "sw").exists()
    # Guarded, the call goes on to the spec (here one that names no scenario there is: its own error, no cluster).
    (tmp_path / "small.toml").write_text(SMALL.replace('"pool12"', '"pool99"'))
    guarded = _script(tmp_path, 'import vil\n\nif __name__ == "__main__":\n'
                                '    vil.sweep("small.toml", out="sw", workers=2)\n')
    assert guarded.returncode == 1 and "sweep.scenarios: pool99: no such scenario file" in guarded.stderr


def test_a_packages_main_module_calling_vil_sweep_unguarded_is_let_through(tmp_path: Path) -> None:
    """`python -m pkg`: spawned workers do not run a package's `__main__` again (multiprocessing.spawn), so
    the guard has nothing to say; the call goes on to the spec (one naming no scenario: its own error)."""
    (tmp_path / "small.toml").write_text(SMALL.replace('"pool12"', '"pool99"'))
    (tmp_path / "pkg").mkdir()
    (tmp_path / "pkg" / "__init__.py").write_text("")
    (tmp_path / "pkg" / "__main__.py").write_text('import vil\n\nvil.sweep("small.toml", out="sw", workers=2)\n')
    done = subprocess.run([sys.executable, "-m", "pkg"], cwd=tmp_path, capture_output=True, text=True, timeout=120,
                          env={**os.environ, "PYTHONPATH": f"{ROOT}{os.pathsep}{tmp_path}"})
    assert done.returncode == 1 and "sweep.scenarios: pool99: no such scenario file" in done.stderr, done.stderr
    assert "if __name__" not in done.stderr


def test_a_run_of_a_scenario_changed_in_python_keeps_its_call_to_read_not_to_resume(tmp_path: Path) -> None:
    """Its fields are no file a call can name: command.txt says so, and nothing offers to resume it with
    a call that would run another mission."""
    changed = vil.scenario("pool12", fields={"mission.duration": "2m", "mission.pool_threshold": 0.7})
    result = vil.run(changed, out=tmp_path)
    command = (result.folder / "command.txt").read_text(encoding="utf-8")
    assert command.startswith("# vil.run(") and "changed in Python" in command
    assert RunFolder(result.folder).resume_command() is None
    plain = vil.run("pool12", duration="2m", out=tmp_path)
    assert RunFolder(plain.folder).resume_command() == f"vil.run({json.dumps(str(changed.path))}, duration='2m', " \
                                                       f"out={str(tmp_path)!r}, resume=True)"
