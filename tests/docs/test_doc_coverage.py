"""Every example command of README.md and docs/*.md has an entry in the registry, and every entry's
command is still in the docs: a new example cannot be added without being run, nor a removed one leave a
dead entry. And the collector's rule (tests/docs/doc_examples.py), on the docs and on made-up blocks."""

from __future__ import annotations

import re
import shlex
import sys
from pathlib import Path

import pytest
from doc_examples import Block, DocBlockError, all_blocks, all_examples, examples, kind, program, split_comment
from doc_harness import ROOT
from doc_registry import REGISTRY, runs_of

PLACEHOLDERS = ("NAME", "SPEC.toml", " DIR", "HOST", "runs/A")


def test_every_example_in_the_docs_has_a_registry_entry() -> None:
    missing = [f"{e.where}: {e.command}" for e in all_examples() if e.command not in REGISTRY]
    assert missing == [], "examples nobody runs; add them to tests/docs/doc_registry.py:\n" + "\n".join(missing)


def test_every_registry_entry_is_an_example_in_the_docs() -> None:
    shown = {e.command for e in all_examples()}
    dead = [command for command in REGISTRY if command not in shown]
    assert dead == [], f"registry entries whose example is gone from the docs: {dead}"


def test_a_variant_says_why_and_a_placeholder_is_always_filled_in() -> None:
    for command, entry in REGISTRY.items():
        assert bool(entry.ci) == bool(entry.why), command
        assert entry.ci != command, command
        if any(p in command for p in PLACEHOLDERS):
            assert entry.ci and not any(p in entry.ci for p in PLACEHOLDERS), command


def test_every_run_is_run_by_the_default_or_the_long_tests() -> None:
    for command, entry in REGISTRY.items():
        assert entry.run in runs_of(entry.room) + runs_of(entry.room, full=True), command


@pytest.mark.parametrize("command", [c for c, e in REGISTRY.items() if e.long_only])
def test_a_long_only_example_still_names_what_there_is(command: str, tmp_path: Path,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    """An example left out of the default run is still held to the code there: its `vil` line parses
    with today's subcommands and flags, and the repository files it names exist."""
    line = REGISTRY[command].line(command, False)
    argv = shlex.split(line)
    for word in argv:
        if re.match(r"^(missions|docs|bench)/\S+\.(toml|py|geojson)$", word):
            assert (ROOT / word).is_file(), word
    if program(line) == "vil":
        from gcs.cli.main import build_parser

        monkeypatch.chdir(tmp_path)
        try:
            build_parser(argv[1:]).parse_args(argv[1:])
        except SystemExit as exc:
            pytest.fail(f"{line!r} no longer parses (exit {exc.code})")
    elif program(line) == "dask":
        assert (Path(sys.executable).parent / "dask").is_file()
    elif argv[1] == "-m":  # python -m MODULE: the module is there
        import importlib.util

        assert program(line) in ("python", ".venv/bin/python") and importlib.util.find_spec(argv[2]), line
    else:
        assert program(line) == ".venv/bin/python" and (ROOT / argv[1]).is_file(), line


def test_the_docs_blocks_are_classed_by_the_rule() -> None:
    classed = [(b.doc, (b.lines[0].split() or [""])[0], kind(b)) for b in all_blocks()]
    kinds = {(doc, first): k for doc, first, k in classed}
    assert kinds["README.md", "Table"] == "output"  # the printed Table II
    assert kinds["README.md", "missiontime/"] == "layout"
    assert kinds["docs/sweeps.md", "[sweep]"] == "code"  # ```toml
    assert kinds["docs/sweeps.md", "import"] == "code"  # ```python
    assert kinds["docs/sweeps.md", "cells/KEY.json"] == "layout"
    assert kinds["docs/strategies.md", "scenario"] == "output"
    assert sum(k == "commands" for _, _, k in classed) >= 10


def block(*lines: str, info: str = "") -> Block:
    return Block("made-up.md", 1, info, lines)


def test_commands_their_claims_and_continuations() -> None:
    found = examples(block(
        "vil run pool12 --outage 92s:112s  # the failsafe holds",
        "",
        "python -m tool --master=udpout:127.0.0.1:14550 \\",
        "    --dialect subcultron",
        "VIL_SIGNING_KEY=x vil run pool12",
        "vil sitl   # then: python missions/listing1.py --connect udp:127.0.0.1:14550",
    ))
    assert [(e.line, e.command, e.claim) for e in found] == [
        (1, "vil run pool12 --outage 92s:112s", "the failsafe holds"),
        (3, "python -m tool --master=udpout:127.0.0.1:14550 --dialect subcultron", ""),
        (5, "VIL_SIGNING_KEY=x vil run pool12", ""),
        (6, "vil sitl", "then: python missions/listing1.py --connect udp:127.0.0.1:14550"),
        (6, "python missions/listing1.py --connect udp:127.0.0.1:14550", ""),
    ]


def test_a_hash_inside_quotes_or_a_word_is_not_a_comment() -> None:
    line = """sed -i 's#"areas/#"missions/areas/#' mine.toml   # paths from mine.toml's folder"""
    command = """sed -i 's#"areas/#"missions/areas/#' mine.toml"""
    assert split_comment(line) == (command, "paths from mine.toml's folder")
    assert split_comment("open http://host/#frag") == ("open http://host/#frag", "")


def test_output_layout_and_code_are_not_run() -> None:
    assert kind(block("  run   avg %   max %", "  pool12 cautious s1   74.67   84.42")) == "output"
    assert kind(block("cells/KEY.json   one per mission", "results.csv      the same rows")) == "layout"
    assert kind(block("vil run", info="toml")) == "code"
    assert examples(block("import pandas as pd", info="python")) == []


def test_a_block_mixing_commands_and_output_is_refused() -> None:
    with pytest.raises(DocBlockError, match="commands mixed with other lines"):
        kind(block("vil run pool12", "  pool12 cautious s1   74.67"))


def test_a_command_of_a_program_the_collector_does_not_know_is_refused() -> None:
    with pytest.raises(DocBlockError, match=r"'bash'.*add it to PROGRAMS"):
        kind(block("bash -c 'vil run'"))
