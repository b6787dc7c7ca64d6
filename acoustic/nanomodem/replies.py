"""What the modem writes back: acknowledgements (`$...`), results (`#...`) and `E`, each ending CR LF.

    $<header>         the command's header repeated at once ($Pxxx, $Bnn, $Uxxxnn, $Mxxxnn, ...)
    $Cx / $C-         $Q's answer: bytes corrected in the last packet (0-8), or it failed to decode
    #Axxx             the address is set                 #AxxxVyyyyy  status: volts = y x 15 / 65536
    #RxxxTyyyyy       xxx answered: range = y x c x 3.125e-5 m         #TO  no answer within 4 s
    #Bxxxnn<data>     a broadcast heard from xxx (a remote's voltage: #Bxxx06Vyyyyy)
    #Unn<data>        a unicast to this unit heard       E            unknown or invalid command

`ReplyParser` reads them back for the driver: what does not parse is dropped and counted by reason.
"""

from __future__ import annotations

from dataclasses import dataclass

from acoustic.airtime import CORRECTABLE_BYTES, MAX_PAYLOAD, MIN_PAYLOAD, RANGE_TICK_S
from acoustic.nanomodem.grammar import Data, Lit, Matcher, Num, Rejected, Template
from acoustic.nanomodem.host_commands import MAX_ADDRESS, Kind

CRLF = b"\r\n"
VOLTS_PER_TICK = 15.0 / 65536.0
MAX_TICKS = 99_999  # five digits
UNKNOWN_REPLY, BAD_TERMINATOR, BAD_VALUE = "unknown_reply", "bad_terminator", "bad_value"


@dataclass(frozen=True)
class Ack:
    """The local acknowledgement of a command: its kind and header numbers."""

    kind: Kind
    address: int | None = None
    length: int | None = None

    def encode(self) -> bytes:
        text = "$" + self.kind.value
        if self.address is not None:
            text += f"{self.address:03d}"
        if self.length is not None:
            text += f"{self.length:02d}"
        return text.encode("ascii") + CRLF


@dataclass(frozen=True)
class Quality:
    corrected: int | None  # None: the last packet failed to decode

    def encode(self) -> bytes:
        return b"$C" + (b"-" if self.corrected is None else str(self.corrected).encode()) + CRLF


@dataclass(frozen=True)
class AddressSet:
    address: int

    def encode(self) -> bytes:
        return f"#A{self.address:03d}".encode() + CRLF


@dataclass(frozen=True)
class Status:
    address: int
    supply_ticks: int

    @property
    def supply_v(self) -> float:
        return self.supply_ticks * VOLTS_PER_TICK

    def encode(self) -> bytes:
        return f"#A{self.address:03d}V{self.supply_ticks:05d}".encode() + CRLF


@dataclass(frozen=True)
class Range:
    address: int
    ticks: int

    def range_m(self, sound_speed_mps: float) -> float:
        return self.ticks * sound_speed_mps * RANGE_TICK_S

    def encode(self) -> bytes:
        return f"#R{self.address:03d}T{self.ticks:05d}".encode() + CRLF


@dataclass(frozen=True)
class Timeout:
    def encode(self) -> bytes:
        return b"#TO" + CRLF


@dataclass(frozen=True)
class Received:
    """A packet heard from the water: a broadcast (with its sender) or a unicast to this unit."""

    data: bytes
    source: int | None = None  # a broadcast's sender; None: a unicast (the unit does not say whose)

    def encode(self) -> bytes:
        head = f"#B{self.source:03d}" if self.source is not None else "#U"
        return f"{head}{len(self.data):02d}".encode() + self.data + CRLF


@dataclass(frozen=True)
class Error:
    def encode(self) -> bytes:
        return b"E" + CRLF


Reply = Ack | Quality | AddressSet | Status | Range | Timeout | Received | Error

_END = Lit(CRLF, BAD_TERMINATOR)
_ADDR = Num("address", 3, 0, MAX_ADDRESS, BAD_VALUE)
_LEN = Num("length", 2, MIN_PAYLOAD, MAX_PAYLOAD, BAD_VALUE)
_TICKS = Num("ticks", 5, 0, MAX_TICKS, BAD_VALUE)


def _lit(text: bytes) -> Lit:
    return Lit(text, UNKNOWN_REPLY)


def _ack(kind: Kind) -> Template[Reply]:
    tokens: list[Lit | Num | Data] = [_lit(b"$" + kind.value.encode())]
    if kind.has_address:
        tokens.append(_ADDR)
    if kind.has_data:
        tokens.append(_LEN)
    return Template((*tokens, _END), lambda f, _d: Ack(kind, f.get("address"), f.get("length")))


TEMPLATES: tuple[Template[Reply], ...] = (
    *(_ack(k) for k in Kind if k not in (Kind.QUALITY, Kind.SET_ADDRESS, Kind.STATUS)),
    Template((_lit(b"$C"), Num("corrected", 1, 0, CORRECTABLE_BYTES, BAD_VALUE), _END),
             lambda f, _d: Quality(f["corrected"])),
    Template((_lit(b"$C-"), _END), lambda _f, _d: Quality(None)),
    Template((_lit(b"#A"), _ADDR, _END), lambda f, _d: AddressSet(f["address"])),
    Template((_lit(b"#A"), _ADDR, _lit(b"V"), Num("ticks", 5, 0, 65535, BAD_VALUE), _END),
             lambda f, _d: Status(f["address"], f["ticks"])),
    Template((_lit(b"#R"), _ADDR, _lit(b"T"), _TICKS, _END), lambda f, _d: Range(f["address"], f["ticks"])),
    Template((_lit(b"#TO"), _END), lambda _f, _d: Timeout()),
    Template((_lit(b"#B"), _ADDR, _LEN, Data("length"), _END), lambda f, d: Received(d, f["address"])),
    Template((_lit(b"#U"), _LEN, Data("length"), _END), lambda _f, d: Received(d)),
    Template((_lit(b"E"), _END), lambda _f, _d: Error()),
)


class ReplyParser:
    """Bytes from the modem to `Reply`s; `Rejected`s counted in `dropped` by reason."""

    def __init__(self) -> None:
        self._matcher = Matcher(TEMPLATES)
        self.dropped: dict[str, int] = {}

    def feed(self, data: bytes) -> list[Reply]:
        out: list[Reply] = []
        for item in self._matcher.feed(data):
            if isinstance(item, Rejected):
                self.dropped[item.reason] = self.dropped.get(item.reason, 0) + item.weight
            else:
                out.append(item)
        return out

    def cut(self, reason: str) -> None:
        """The stream ended (the device vanished): a reply under way is dropped as `reason`."""
        if self._matcher.busy:
            self._matcher.abandon()
            self.dropped[reason] = self.dropped.get(reason, 0) + 1
