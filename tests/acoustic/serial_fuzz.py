"""Random and mutated serial inputs for the nanomodem's parsers and emulator (the tests' short fuzz
and bench/fuzz_modem.py's long one).

An input is random bytes, or a valid command or reply (every kind, random fields, data holding the
protocol's own bytes) mutated 1-4 times: a byte flipped, inserted or deleted, a slice repeated, the
end cut off, another message spliced in, `$`, `#` or CR LF put somewhere. Each goes to the three
readers of a serial line: the emulator's command parser (with its 2 ms gap rule: inputs arrive
0-4 ms apart), the driver's reply parser, and the emulator itself (which answers over the channel).
"""

from __future__ import annotations

import numpy as np

from acoustic.nanomodem.emulator import ModemEmulator, RemoteUnit
from acoustic.nanomodem.host_commands import Command, CommandParser, Kind
from acoustic.nanomodem.replies import (
    Ack,
    AddressSet,
    Error,
    Quality,
    Range,
    Received,
    ReplyParser,
    Status,
    Timeout,
)
from acoustic.params import AcousticParams

SPECIAL = (b"$", b"#", b"\r\n", b"\r", b"\n", b"E")


class SerialFuzz:
    def __init__(self, seed: int) -> None:
        self.rng = np.random.default_rng(seed)
        self.commands = CommandParser()
        self.replies = ReplyParser()
        self.emulator = ModemEmulator(AcousticParams(), (RemoteUnit(5, (300.0, 0.0, 5.0)),
                                                         RemoteUnit(9, (1800.0, 0.0, 5.0))),
                                      np.random.default_rng(seed))
        self.t_s = 0.0
        self.command_counts: dict[str, int] = {}

    def _data(self) -> bytes:
        n = int(self.rng.integers(2, 65))
        data = bytearray(self.rng.integers(0, 256, n, dtype=np.uint8).tobytes())
        for _ in range(int(self.rng.integers(0, 3))):
            special = SPECIAL[int(self.rng.integers(len(SPECIAL)))]
            at = int(self.rng.integers(0, n))
            data[at:at + len(special)] = special
        return bytes(data[:n]).ljust(2, b"$")

    def valid(self) -> bytes:
        """One valid command or reply, every kind equally likely."""
        a = int(self.rng.integers(0, 256))
        kind = list(Kind)[int(self.rng.integers(len(Kind)))]
        if self.rng.random() < 0.5:
            return Command(kind, a if kind.has_address else None, self._data() if kind.has_data else b"").encode()
        choice = int(self.rng.integers(9))
        reply = [Ack(Kind.PING, a), Ack(Kind.UNICAST_ACK, a, int(self.rng.integers(2, 65))),
                 Quality(None if a > 200 else a % 9), AddressSet(a), Status(a, int(self.rng.integers(65536))),
                 Range(a, int(self.rng.integers(100_000))), Timeout(), Error(),
                 Received(self._data(), None if a > 127 else a)][choice]
        return reply.encode()

    def random_input(self) -> bytes:
        return self.rng.integers(0, 256, int(self.rng.integers(0, 101)), dtype=np.uint8).tobytes()

    def mutated_input(self) -> bytes:
        data = bytearray(self.valid())
        for _ in range(int(self.rng.integers(1, 5))):
            op = int(self.rng.integers(7))
            at = int(self.rng.integers(0, len(data) + 1))
            if op == 0 and data:
                data[min(at, len(data) - 1)] ^= 1 << int(self.rng.integers(8))
            elif op == 1:
                data[at:at] = bytes([int(self.rng.integers(256))])
            elif op == 2 and data:
                del data[min(at, len(data) - 1)]
            elif op == 3:
                data[at:at] = data[at:at + int(self.rng.integers(1, 8))]
            elif op == 4:
                del data[at:]
            elif op == 5:
                data[at:at] = self.valid()
            else:
                data[at:at] = SPECIAL[int(self.rng.integers(len(SPECIAL)))]
        return bytes(data)

    def feed(self, data: bytes) -> None:
        """One input into the three readers, `dt` of 0-4 ms after the last (the emulator's water runs on)."""
        self.t_s += float(self.rng.uniform(0.0, 0.004))
        for item in self.commands.feed(data, self.t_s):
            if not isinstance(item, Command):
                self.command_counts[item.reason] = self.command_counts.get(item.reason, 0) + item.weight
        self.replies.feed(data)
        self.emulator.advance(self.t_s)
        self.emulator.from_host(data, self.t_s)
