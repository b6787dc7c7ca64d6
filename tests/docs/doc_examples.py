"""The examples of README.md and docs/*.md: every fenced block, what kind it is, and its command lines.

The rule, decided by a block's content (`kind`):

- A block whose info string names a language other than a shell (```toml, ```python) is `code`.
- Otherwise each logical line (a line ending in `\\` goes on on the next) is read: it is a command when
  its first word, after any NAME=VALUE environment prefixes, is one of `PROGRAMS`.
- A block of commands only is `commands`: each logical line is an `Example`; its text before the first
  unquoted `#` that follows a space is the command, the rest the example's claim. A claim that reads
  `then: COMMAND` (a command to run next, against the first) is an example of its own too.
- A block without any command is an output sample (`output`: a printed table, figures) or a layout
  (`layout`: a tree of files or parts, most lines at its left margin name a path); neither is run.
- A block that mixes the two, or whose lines start with another program found on PATH (`curl ...`),
  is refused with `DocBlockError`: a doc keeps its commands apart from their output, and an example
  of a program this collector does not know is added to `PROGRAMS` (and so to the registry) first.
"""

from __future__ import annotations

import os
import re
import shutil
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

ROOT = Path(__file__).resolve().parents[2]
PROGRAMS = ("vil", "python", ".venv/bin/python", "make", "cp", "sed", "dask")
SHELL_LANGUAGES = ("", "sh", "shell", "bash", "console")
ENV_PREFIX = re.compile(r"^(?:[A-Za-z_][A-Za-z0-9_]*=\S*\s+)*")
FENCE = re.compile(r"^(\s*)```(\S*)\s*$")
PATH_WORD = re.compile(r"^[\w.()-]+(/[\w.*-]*)+$|^[\w-]+\.[A-Za-z]\w*$")  # missiontime/, cells/KEY.json, sweep.json

Kind = Literal["commands", "output", "layout", "code"]


class DocBlockError(ValueError):
    """A fenced block the rule cannot class: it names the file and line."""


@dataclass(frozen=True)
class Block:
    doc: str  # the file, relative to the repository: "README.md", "docs/sweeps.md"
    line: int  # the first line inside the fence, 1-based
    info: str  # the fence's info string: "", "toml", "python"
    lines: tuple[str, ...]  # the block's physical lines


@dataclass(frozen=True)
class Example:
    doc: str
    line: int  # the example's first physical line, 1-based
    command: str  # the exact command text: continuation lines joined by one space, no comment
    claim: str  # the comment after the command, without its `#`; "" when there is none

    @property
    def where(self) -> str:
        return f"{self.doc}:{self.line}"


def doc_files(root: Path = ROOT) -> list[Path]:
    return [root / "README.md", *sorted((root / "docs").glob("*.md"))]


def blocks(path: Path, root: Path = ROOT) -> list[Block]:
    """The fenced blocks of a markdown file, in order."""
    found: list[Block] = []
    open_at: tuple[int, str] | None = None
    body: list[str] = []
    for number, text in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
        fence = FENCE.match(text)
        if open_at is None and fence:
            open_at, body = (number + 1, fence.group(2)), []
        elif open_at is not None and fence and not fence.group(2):
            found.append(Block(str(path.relative_to(root)), open_at[0], open_at[1], tuple(body)))
            open_at = None
        elif open_at is not None:
            body.append(text)
    if open_at is not None:
        raise DocBlockError(f"{path.relative_to(root)}:{open_at[0] - 1}: a fence that is never closed")
    return found


def logical_lines(block: Block) -> Iterator[tuple[int, str]]:
    """(first line number, text) per logical line: continuations joined by one space, blank lines skipped."""
    pending: list[str] = []
    start = 0
    for offset, text in enumerate(block.lines):
        if not pending:
            if not text.strip():
                continue
            start = block.line + offset
        stripped = text.rstrip()
        if stripped.endswith("\\"):
            pending.append(stripped[:-1].strip())
            continue
        pending.append(stripped.strip() if len(pending) else stripped.lstrip())
        yield start, " ".join(part for part in pending if part)
        pending = []
    if pending:
        raise DocBlockError(f"{block.doc}:{start}: a continuation line ends the block")


def split_comment(line: str) -> tuple[str, str]:
    """(command, claim): the claim starts at the first `#` outside quotes that follows a blank."""
    quote = ""
    for i, char in enumerate(line):
        if quote:
            quote = "" if char == quote else quote
        elif char in "'\"":
            quote = char
        elif char == "#" and (i == 0 or line[i - 1].isspace()):
            return line[:i].rstrip(), line[i + 1 :].strip()
    return line.rstrip(), ""


def program(line: str) -> str:
    """The first word of a shell line after its NAME=VALUE prefixes."""
    rest = ENV_PREFIX.sub("", line, count=1)
    return rest.split(maxsplit=1)[0] if rest.strip() else ""


def _venv_path() -> str:
    return f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}"


def kind(block: Block) -> Kind:
    """What the block is, by the module's rule; `DocBlockError` for a block the rule refuses."""
    if block.info.lower() not in SHELL_LANGUAGES:
        return "code"
    lines = [text for _, text in logical_lines(block)]
    commands = [program(text) in PROGRAMS for text in lines]
    if all(commands) and lines:
        return "commands"
    if any(commands):
        mixed = next(t for t, c in zip(lines, commands, strict=True) if c)
        raise DocBlockError(f"{block.doc}:{block.line}: commands mixed with other lines ({mixed!r}): "
                            "keep the commands of a block apart from their output")
    for text in lines:
        word = program(text)
        if word and "/" not in word and shutil.which(word, path=_venv_path()):
            raise DocBlockError(f"{block.doc}:{block.line}: {text!r} starts with the program {word!r}, which "
                                "tests/docs/doc_examples.py does not know: add it to PROGRAMS and the registry")
    heads = [text for text in block.lines if text[:1].strip()] or lines  # the lines at the left margin
    paths = sum(any(PATH_WORD.match(word) for word in text.split()) for text in heads)
    return "layout" if paths * 2 > len(heads) else "output"


def examples(block: Block) -> list[Example]:
    """The examples of a command block (none for other kinds)."""
    if kind(block) != "commands":
        return []
    found = []
    for start, text in logical_lines(block):
        example = Example(block.doc, start, *split_comment(text))
        found.append(example)
        then = re.match(r"^then:\s+(.*)$", example.claim)
        if then and program(then.group(1)) in PROGRAMS:
            found.append(Example(block.doc, start, then.group(1).strip(), ""))
    return found


def all_blocks(root: Path = ROOT) -> list[Block]:
    return [b for path in doc_files(root) for b in blocks(path, root)]


def all_examples(root: Path = ROOT) -> list[Example]:
    """Every example command of README.md and docs/*.md, in document order."""
    return [e for b in all_blocks(root) for e in examples(b)]
