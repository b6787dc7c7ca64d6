"""What the host writes to the modem: `$` + a letter, then fixed fields, no terminator.

    $Axxx         set the address (xxx 000-255)      $?          status (address, supply voltage)
    $Pxxx         ping xxx (range, or #TO)           $Vxxx       xxx's supply voltage
    $Bnn<data>    broadcast nn bytes (02-64)         $Uxxxnn...  unicast to xxx
    $Mxxxnn...    unicast, acknowledged (range)      $Txxx       test message to xxx
    $Exxxnn...    echo: xxx sends the data back      $Q          quality of the last packet

Data may hold any byte ($, #, CR, LF too): its length is given. The unit drops a command whose
bytes come more than about 2 ms apart and answers `E`; `CommandParser` does the same, given each
chunk's arrival time. Bytes outside a command are dropped and counted (`stray_byte`), unanswered.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

from acoustic.airtime import MAX_PAYLOAD, MIN_PAYLOAD
from acoustic.nanomodem.grammar import Data, Lit, Matcher, Num, Rejected, Template

GAP_S = 0.002  # the unit's limit between a command's bytes
MAX_ADDRESS = 255
UNKNOWN_COMMAND, BAD_ADDRESS, BAD_LENGTH, GAP = "unknown_command", "bad_address", "bad_length", "gap"


class Kind(Enum):
    SET_ADDRESS = "A"
    STATUS = "?"
    PING = "P"
    VOLTAGE = "V"
    BROADCAST = "B"
    UNICAST = "U"
    UNICAST_ACK = "M"
    TEST = "T"
    ECHO = "E"
    QUALITY = "Q"

    @property
    def has_address(self) -> bool:
        return self not in (Kind.STATUS, Kind.BROADCAST, Kind.QUALITY)

    @property
    def has_data(self) -> bool:
        return self in (Kind.BROADCAST, Kind.UNICAST, Kind.UNICAST_ACK, Kind.ECHO)


@dataclass(frozen=True)
class Command:
    kind: Kind
    address: int | None = None  # the remote unit's (the new own address for SET_ADDRESS)
    data: bytes = b""

    def __post_init__(self) -> None:
        if self.kind.has_address != (self.address is not None):
            raise ValueError(f"{self.kind.name} {'needs' if self.kind.has_address else 'takes no'} address")
        if self.address is not None and not 0 <= self.address <= MAX_ADDRESS:
            raise ValueError(f"address {self.address} is outside 0..{MAX_ADDRESS}")
        if self.kind.has_data and not MIN_PAYLOAD <= len(self.data) <= MAX_PAYLOAD:
            raise ValueError(f"{self.kind.name} carries {MIN_PAYLOAD}..{MAX_PAYLOAD} bytes, got {len(self.data)}")
        if not self.kind.has_data and self.data:
            raise ValueError(f"{self.kind.name} carries no data")

    def header(self) -> bytes:
        """`$`, the letter and the numbers: what the unit's acknowledgement repeats."""
        text = "$" + self.kind.value
        if self.address is not None:
            text += f"{self.address:03d}"
        if self.kind.has_data:
            text += f"{len(self.data):02d}"
        return text.encode("ascii")

    def encode(self) -> bytes:
        return self.header() + self.data


def _template(kind: Kind) -> Template[Command]:
    tokens: list[Lit | Num | Data] = [Lit(b"$", UNKNOWN_COMMAND), Lit(kind.value.encode(), UNKNOWN_COMMAND)]
    if kind.has_address:
        tokens.append(Num("address", 3, 0, MAX_ADDRESS, BAD_ADDRESS))
    if kind.has_data:
        tokens += [Num("length", 2, MIN_PAYLOAD, MAX_PAYLOAD, BAD_LENGTH), Data("length")]
    return Template(tuple(tokens), lambda f, d: Command(kind, f.get("address"), d))


TEMPLATES = tuple(_template(k) for k in Kind)


class CommandParser:
    """Bytes from the host, with their arrival times (s), to `Command`s and `Rejected`s (each but a
    stray byte answered `E` by the unit)."""

    def __init__(self, gap_s: float = GAP_S) -> None:
        self.gap_s = gap_s
        self._matcher = Matcher(TEMPLATES)
        self._last_s = float("-inf")

    def feed(self, data: bytes, t_s: float) -> list[Command | Rejected]:
        """A chunk that arrived at `t_s` (its bytes back to back, faster than 9600 baud is fine)."""
        out = self.expire(t_s) + self._matcher.feed(data)
        if data:
            self._last_s = t_s
        return out

    def expire(self, t_s: float) -> list[Command | Rejected]:
        """The command under way, rejected (`gap`) if its last byte came `gap_s` or more before `t_s`."""
        deadline = self.deadline_s()
        if deadline is not None and t_s >= deadline:  # the same sum as deadline_s: at it, never short of it
            return [Rejected(GAP, self._matcher.abandon())]
        return []

    def deadline_s(self) -> float | None:
        """When the command under way will be rejected for its gap, or None."""
        return self._last_s + self.gap_s if self._matcher.busy else None
