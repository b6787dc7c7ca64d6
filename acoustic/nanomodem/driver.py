"""The GCS's nanomodem driver: commands out, replies and packets heard in, as typed values.

One class over a `BytePort` (`ports.py`): a real unit or `vil modem`'s pty through pyserial, or an
in-process pipe to the emulator in lockstep. Every wait is bounded on the driver's `Clock` and ends
in a written-down `Outcome`:

- the local acknowledgement (`$...` or `#A...`, `$C..`) within `ACK_WAIT_S` (the unit answers at
  once; NO_REPLY past it);
- a ping's or an acknowledged unicast's result (`#R...` or the unit's own `#TO` after 4 s) within
  `RESULT_WAIT_S` (NO_REPLY past it: the unit said nothing at all);
- `E` ends a wait as ERROR; a port that has gone, as CLOSED (and every later call too).

Packets heard while waiting (`#B...`, `#U...`) are kept in `inbox`, never lost to a wait; a reply
no wait asked for is dropped and counted (`unexpected_reply`), as is every byte that does not parse
(`ReplyParser.dropped`, by reason).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum

from acoustic.airtime import PING_TIMEOUT_S
from acoustic.nanomodem.host_commands import Command, Kind
from acoustic.nanomodem.ports import BytePort, PortClosed
from acoustic.nanomodem.replies import (
    Ack,
    AddressSet,
    Error,
    Quality,
    Range,
    Received,
    Reply,
    ReplyParser,
    Status,
    Timeout,
)
from missiontime.clocks import Clock

ACK_WAIT_S = 2.0  # the unit answers at once; this bound allows for a loaded host
RESULT_WAIT_S = PING_TIMEOUT_S + 1.0 + 2 * 1.105  # the unit's #TO, a long packet each way, a margin
POLL_S = 0.005  # between reads while waiting (the wall clock sleeps; a virtual one runs the world)


class Outcome(Enum):
    REPLIED = "replied"
    ERROR = "error"  # the unit answered E
    TIMEOUT = "timeout"  # the unit answered #TO (nobody answered it on the water)
    NO_REPLY = "no_reply"  # the unit said nothing within the driver's bound
    CLOSED = "closed"  # the port has gone


@dataclass(frozen=True)
class Result:
    outcome: Outcome
    reply: Reply | None = None

    @property
    def ok(self) -> bool:
        return self.outcome is Outcome.REPLIED


QUEUE_MAX = 4096  # replies and packets kept unread (hours of a busy channel at 9600 baud)


class ModemDriver:
    def __init__(self, port: BytePort, clock: Clock, sound_speed_mps: float = 1500.0) -> None:
        self.port, self.clock, self.sound_speed_mps = port, clock, sound_speed_mps
        self.parser = ReplyParser()
        # Bounded: a driver nobody reads keeps the newest; what fell off is counted (`dropped`).
        self.inbox: deque[Received] = deque(maxlen=QUEUE_MAX)
        self.unexpected = 0
        self.overflowed = 0
        self.closed_reason: str | None = None
        self._replies: deque[Reply] = deque(maxlen=QUEUE_MAX)
        self._waiting = False  # a wait is reading replies (packets heard go to it as well as the inbox)
        # How a wait passes time between reads: the clock's sleep, or a caller's that may end the wait
        # by raising (a mission loop's, which an operator's quit interrupts).
        self.sleep: Callable[[float], None] = clock.sleep

    @property
    def dropped(self) -> dict[str, int]:
        """Everything not taken, by reason: unparsed bytes and replies nobody waited for."""
        counts = dict(self.parser.dropped)
        if self.unexpected:
            counts["unexpected_reply"] = self.unexpected
        if self.overflowed:
            counts["queue_full"] = self.overflowed
        return counts

    # ---- the lines
    def poll(self) -> None:
        """Read what has arrived: packets heard to `inbox`, other replies queued for the waits."""
        if self.closed_reason is not None:
            return
        try:
            data = self.port.read()
        except PortClosed as exc:
            self._closed(str(exc))
            return
        for reply in self.parser.feed(data):
            if isinstance(reply, Received):
                self.overflowed += len(self.inbox) == QUEUE_MAX
                self.inbox.append(reply)  # a wait that takes it (a voltage answer) takes it from here
                if not self._waiting:  # heard between waits: a packet for the inbox only
                    continue
            self.overflowed += len(self._replies) == QUEUE_MAX
            self._replies.append(reply)

    def send(self, command: Command) -> bool:
        """Write one command whole (its bytes back to back, as the unit needs); False if the port has gone."""
        if self.closed_reason is not None:
            return False
        self._drop_unawaited()
        try:
            self.port.write(command.encode())
        except PortClosed as exc:
            self._closed(str(exc))
            return False
        return True

    def wait_for(self, accept: Callable[[Reply], bool], bound_s: float) -> Result:
        """The first reply `accept` takes (or E, or #TO), within `bound_s` of the clock."""
        self._waiting = True
        try:
            return self._wait(accept, self.clock.time() + bound_s)
        finally:
            self._waiting = False

    def _wait(self, accept: Callable[[Reply], bool], deadline: float) -> Result:
        while True:
            self.poll()
            while self._replies:
                reply = self._replies.popleft()
                if accept(reply):
                    if isinstance(reply, Received) and reply in self.inbox:
                        self.inbox.remove(reply)
                    return Result(Outcome.REPLIED, reply)
                if isinstance(reply, Error):
                    return Result(Outcome.ERROR, reply)
                if isinstance(reply, Timeout):
                    return Result(Outcome.TIMEOUT, reply)
                if not isinstance(reply, Received):  # a packet heard stays in the inbox
                    self.unexpected += 1
            if self.closed_reason is not None:
                return Result(Outcome.CLOSED)
            if self.clock.time() >= deadline:
                return Result(Outcome.NO_REPLY)
            self.sleep(POLL_S)

    def received(self) -> list[Received]:
        """The packets heard so far (broadcasts with their sender, unicasts to this unit), oldest first."""
        self.poll()
        out = list(self.inbox)
        self.inbox.clear()
        return out

    # ---- the commands
    def set_address(self, address: int) -> Result:
        return self._ack(Command(Kind.SET_ADDRESS, address), lambda r: r == AddressSet(address))

    def status(self) -> Result:
        return self._ack(Command(Kind.STATUS), lambda r: isinstance(r, Status))

    def quality(self) -> Result:
        return self._ack(Command(Kind.QUALITY), lambda r: isinstance(r, Quality))

    def broadcast(self, data: bytes) -> Result:
        return self._acked(Command(Kind.BROADCAST, None, data))

    def unicast(self, address: int, data: bytes) -> Result:
        return self._acked(Command(Kind.UNICAST, address, data))

    def test(self, address: int) -> Result:
        return self._acked(Command(Kind.TEST, address))

    def echo(self, address: int, data: bytes) -> Result:
        """The data goes to `address` and comes back into `inbox` (if both legs get through)."""
        return self._acked(Command(Kind.ECHO, address, data))

    def ping(self, address: int) -> Result:
        """`Range` (its `range_m(c)`), or TIMEOUT."""
        return self._with_result(Command(Kind.PING, address), lambda r: isinstance(r, Range) and r.address == address)

    def unicast_ack(self, address: int, data: bytes) -> Result:
        """Delivered: `Range` (the acknowledgement's round trip); lost either way: TIMEOUT."""
        return self._with_result(Command(Kind.UNICAST_ACK, address, data),
                                 lambda r: isinstance(r, Range) and r.address == address)

    def voltage(self, address: int) -> Result:
        """The remote unit's supply: a `Received` from it holding b"Vyyyyy" (volts = y x 15 / 65536)."""
        return self._with_result(Command(Kind.VOLTAGE, address),
                                 lambda r: isinstance(r, Received) and r.source == address and len(r.data) == 6)

    def _ack(self, command: Command, accept: Callable[[Reply], bool]) -> Result:
        if not self.send(command):
            return Result(Outcome.CLOSED)
        return self.wait_for(accept, ACK_WAIT_S)

    def _acked(self, command: Command) -> Result:
        ack = Ack(command.kind, command.address, len(command.data) if command.kind.has_data else None)
        return self._ack(command, lambda r: r == ack)

    def _with_result(self, command: Command, accept: Callable[[Reply], bool]) -> Result:
        first = self._acked(command)
        if not first.ok:
            return first
        return self.wait_for(accept, RESULT_WAIT_S)

    def _drop_unawaited(self) -> None:
        """Replies left from before this command (a late answer): counted, not mistaken for its own."""
        self.poll()
        self.unexpected += sum(1 for r in self._replies if not isinstance(r, Received))
        self._replies.clear()

    def _closed(self, reason: str) -> None:
        self.closed_reason = reason
        self.parser.cut("truncated")

