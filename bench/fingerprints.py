"""The outputs of lockstep runs as digests, to hold a refactoring to the byte (no timing: a check, not a speed).

Runs every shipped scenario at its defaults, the Table II reproduction, a lossy run, a signed swarm and
bay120-sleep for 4 h, each as `vil run` runs it (a subprocess of this interpreter), and prints one line per
file: result.json without its wall time and folder, every .tlog, event log and traces.npz. `--save FILE` keeps
them; `--compare FILE` prints what differs from a kept set and exits 1 if anything does.

    .venv/bin/python bench/fingerprints.py --save before.txt      # at the old head (or PYTHONPATH=OLD_CHECKOUT)
    .venv/bin/python bench/fingerprints.py --compare before.txt   # at the new one (a minute or two)
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

MISSIONS = Path(__file__).resolve().parents[1] / "missions"  # read here, not imported: it runs on older heads too
VOLATILE = ("wall_s", "out_dir")  # what differs between two runs of the same mission
# Labels a later version added whose value is what every run before it was: left out, so digests compare
# across the change (issue 37 named each run's platform; these runs are all lockstep's).
LABELS = {"platform": "lockstep"}
DIGESTED = (".tlog", ".jsonl", ".npz")
EXTRA_RUNS: tuple[tuple[str, tuple[str, ...], dict[str, str]], ...] = (
    ("table2", (), {}),
    ("lossy", ("pool12", "--loss", "0.2", "--latency", "200ms", "--seed", "3"), {}),
    ("signed", ("pool12x2",), {"VIL_SIGNING_KEY": "secret"}),
    ("sleep4h", ("bay120-sleep", "--duration", "4h"), {}),
)


def stripped(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: stripped(v) for k, v in value.items() if k not in VOLATILE and LABELS.get(k, ...) != v}
    if isinstance(value, list):
        return [stripped(v) for v in value]
    return value


def digest(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()[:16]


def run(out: Path, args: tuple[str, ...], env: dict[str, str]) -> None:
    done = subprocess.run([sys.executable, "-m", "gcs.cli", "run", *args, "--out", str(out), "--jobs", "1"],
                          capture_output=True, text=True, env=os.environ | env, timeout=1800)
    if done.returncode not in (0, 3):  # 3: finished with an aMussel off its position, a result too
        raise SystemExit(f"vil run {' '.join(args)}: exit {done.returncode}: {done.stderr.strip()[-300:]}")


def fingerprints() -> dict[str, str]:
    lines: dict[str, str] = {}
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        shipped = sorted(p.stem for p in MISSIONS.glob("*.toml"))
        runs = [(name, (name,), {}) for name in shipped] + list(EXTRA_RUNS)
        for label, args, env in runs:
            run(root / label, args, env)
            for folder in sorted(p.parent for p in (root / label).glob("*/result.json")):
                key = f"{label}/{folder.name}"
                result = json.loads((folder / "result.json").read_text(encoding="utf-8"))
                lines[f"{key} result.json"] = digest(json.dumps(stripped(result), sort_keys=True).encode())
                for f in sorted(p for p in folder.iterdir() if p.suffix in DIGESTED):
                    lines[f"{key} {f.name}"] = digest(f.read_bytes())
    return lines


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--save", type=Path, help="write the digests to FILE")
    parser.add_argument("--compare", type=Path, help="compare with the digests in FILE; exit 1 if any differs")
    args = parser.parse_args()
    now = fingerprints()
    text = "".join(f"{k} {v}\n" for k, v in now.items())
    if args.save:
        args.save.write_text(text, encoding="utf-8")
    if not args.compare:
        print(text, end="")
        return 0
    kept = dict(line.rsplit(" ", 1) for line in args.compare.read_text(encoding="utf-8").splitlines())
    differ = sorted(k for k in kept.keys() | now.keys() if kept.get(k) != now.get(k))
    for k in differ:
        print(f"differs: {k}: {kept.get(k, '-')} -> {now.get(k, '-')}")
    print(f"{len(now)} digests, {len(differ)} differ" + ("" if differ else ": identical"))
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
