"""Matching a byte stream against templates, one byte at a time (both directions of the protocol).

A template is a sequence of tokens: a literal, a fixed-width decimal number with its range, or data
whose length an earlier number gave. Several templates are matched in parallel (`#Axxx` and
`#AxxxVyyyyy` share a prefix); when none can go on, what was taken is rejected with the reason of the
template that got furthest, and the byte that broke it starts afresh if a template can begin with it.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass
from typing import Generic, TypeVar

T = TypeVar("T")

STRAY = "stray_byte"  # bytes outside any message: dropped, counted a byte each (`weight`)
BAD_DIGIT = "bad_digit"


@dataclass(frozen=True)
class Lit:
    text: bytes
    reason: str  # why a message is rejected when this literal is not there


@dataclass(frozen=True)
class Num:
    name: str
    width: int
    lo: int
    hi: int
    reason: str  # why a message is rejected when the number is out of range


@dataclass(frozen=True)
class Data:
    length_field: str  # the Num giving its length


Token = Lit | Num | Data


@dataclass(frozen=True)
class Template(Generic[T]):
    tokens: tuple[Token, ...]
    build: Callable[[dict[str, int], bytes], T]


@dataclass(frozen=True)
class Rejected:
    reason: str
    raw: bytes

    @property
    def weight(self) -> int:
        """What it counts for: a run of stray bytes a byte each, anything else once."""
        return len(self.raw) if self.reason == STRAY else 1


class _Cursor(Generic[T]):
    __slots__ = ("consumed", "data", "digits", "fields", "pos", "template", "token")

    def __init__(self, template: Template[T]) -> None:
        self.template, self.token, self.pos, self.consumed = template, 0, 0, 0
        self.digits = 0
        self.fields: dict[str, int] = {}
        self.data = bytearray()

    def step(self, byte: int) -> str | None:
        """Take one byte: None if it fits, else the rejection's reason."""
        tok = self.template.tokens[self.token]
        if isinstance(tok, Lit):
            if tok.text[self.pos] != byte:
                return tok.reason
            self.pos += 1
            done = self.pos == len(tok.text)
        elif isinstance(tok, Num):
            if not 0x30 <= byte <= 0x39:
                return BAD_DIGIT
            self.digits = self.digits * 10 + byte - 0x30
            self.pos += 1
            done = self.pos == tok.width
            if done:
                if not tok.lo <= self.digits <= tok.hi:
                    self.consumed += 1  # a number, out of range: further in than a wrong letter here
                    return tok.reason
                self.fields[tok.name] = self.digits
                self.digits = 0
        else:
            self.data.append(byte)
            done = len(self.data) == self.fields[tok.length_field]
        self.consumed += 1
        if done:
            self.token += 1
            self.pos = 0
        return None

    def data_wanted(self) -> int:
        """Bytes the data token under way still takes (0 if the cursor is not in data)."""
        tokens = self.template.tokens
        if self.token == len(tokens):
            return 0
        tok = tokens[self.token]
        return self.fields[tok.length_field] - len(self.data) if isinstance(tok, Data) else 0

    def take_data(self, chunk: bytes) -> None:
        """Data bytes that do not finish the token (`data_wanted` less at least one): what `step` would
        do with each, at once."""
        self.data += chunk
        self.consumed += len(chunk)

    @property
    def complete(self) -> bool:
        return self.token == len(self.template.tokens)

    def result(self) -> T:
        return self.template.build(self.fields, bytes(self.data))


class Matcher(Generic[T]):
    """Bytes in, messages (or `Rejected`) out."""

    def __init__(self, templates: tuple[Template[T], ...]) -> None:
        self.templates = templates
        # Templates by the byte they begin with (each begins with a literal): a stray byte costs a lookup.
        self._by_first: dict[int, tuple[Template[T], ...]] = {}
        for t in templates:
            first = t.tokens[0]
            assert isinstance(first, Lit), "a template begins with a literal"
            self._by_first[first.text[0]] = (*self._by_first.get(first.text[0], ()), t)
        self._live: list[_Cursor[T]] = []
        self._raw = bytearray()
        self._starts = re.compile(b"[" + b"".join(re.escape(bytes([b])) for b in self._by_first) + b"]")

    @property
    def busy(self) -> bool:
        """Part of a message has been taken."""
        return bool(self._live)

    def abandon(self) -> bytes:
        """Forget the message under way; its bytes."""
        raw = bytes(self._raw)
        self._live, self._raw = [], bytearray()
        return raw

    def feed(self, data: bytes) -> list[T | Rejected]:
        """Bytes arrived together: what they finished; a run of bytes that begins nothing is one
        `Rejected` (STRAY) found at once, not byte by byte (garbage is most of a hostile stream)."""
        out: list[T | Rejected] = []
        i, n = 0, len(data)
        while i < n:
            live = self._live
            if not live:
                found = self._starts.search(data, i)
                j = found.start() if found else n
                if j > i:
                    out.append(Rejected(STRAY, data[i:j]))
                    i = j
                    continue
            elif len(live) == 1 and (wanted := live[0].data_wanted()) > 1:
                # Inside a payload any byte fits: all but its last at once (the last finishes it, byte-wise).
                chunk = data[i:i + wanted - 1]
                live[0].take_data(chunk)
                self._raw += chunk
                i += len(chunk)
                continue
            out += self.push(data[i])
            i += 1
        return out

    def push(self, byte: int) -> list[T | Rejected]:
        """One byte: what it finished (a message, a rejection; a rejection and then what the breaking
        byte began or was), usually nothing."""
        if not self._live:
            return self._begin(byte)
        reasons: list[tuple[int, str]] = []
        survivors: list[_Cursor[T]] = []
        for cursor in self._live:
            why = cursor.step(byte)
            if why is None:
                if cursor.complete:
                    self.abandon()
                    return [cursor.result()]
                survivors.append(cursor)
            else:
                reasons.append((cursor.consumed, why))
        if survivors:
            self._live = survivors
            self._raw.append(byte)
            return []
        rejected = Rejected(max(reasons)[1], self.abandon())
        after = self._begin(byte)  # the breaking byte may begin the next message
        if len(after) == 1 and isinstance(after[0], Rejected) and after[0].reason == STRAY:
            return [Rejected(rejected.reason, rejected.raw + after[0].raw)]  # it began nothing: it was this one's
        return [rejected, *after]

    def _begin(self, byte: int) -> list[T | Rejected]:
        live = []
        for template in self._by_first.get(byte, ()):
            cursor = _Cursor(template)
            if cursor.step(byte) is None:
                if cursor.complete:
                    return [cursor.result()]
                live.append(cursor)
        if not live:
            return [Rejected(STRAY, bytes([byte]))]
        self._live, self._raw = live, bytearray([byte])
        return []
