"""The nanomodem's serial protocol: commands and replies, byte for byte, whole or a byte at a time."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from acoustic.nanomodem.grammar import Rejected
from acoustic.nanomodem.host_commands import Command, CommandParser, Kind
from acoustic.nanomodem.replies import Ack, AddressSet, Error, Quality, Range, Received, ReplyParser, Status, Timeout

# The unit's bytes as its guide writes them (NOTES.md "Its serial protocol").
WIRE = [
    (Command(Kind.SET_ADDRESS, 7), b"$A007"),
    (Command(Kind.STATUS), b"$?"),
    (Command(Kind.PING, 5), b"$P005"),
    (Command(Kind.VOLTAGE, 255), b"$V255"),
    (Command(Kind.BROADCAST, None, b"hello"), b"$B05hello"),
    (Command(Kind.UNICAST, 12, b"$#\r\n"), b"$U01204$#\r\n"),
    (Command(Kind.UNICAST_ACK, 3, b"ab"), b"$M00302ab"),
    (Command(Kind.TEST, 9), b"$T009"),
    (Command(Kind.ECHO, 0, bytes(range(64))), b"$E00064" + bytes(range(64))),
    (Command(Kind.QUALITY), b"$Q"),
]


@pytest.mark.parametrize(("command", "wire"), WIRE)
def test_each_command_encodes_and_parses_as_the_unit_writes_it(command: Command, wire: bytes) -> None:
    assert command.encode() == wire
    assert CommandParser().feed(wire, 0.0) == [command]


def test_a_burst_of_every_command_back_to_back_parses_faster_than_9600_baud() -> None:
    burst = b"".join(w for _, w in WIRE)
    assert CommandParser().feed(burst, 0.0) == [c for c, _ in WIRE]


def test_invalid_commands_are_rejected_by_reason() -> None:
    cases = {b"$X": "unknown_command", b"$P9x9": "bad_digit", b"$P256": "bad_address", b"$B01a": "bad_length",
             b"$B65": "bad_length", b"$U005x1": "bad_digit", b"$A": None}
    for wire, reason in cases.items():
        got = CommandParser().feed(wire, 0.0)
        if reason is None:
            assert got == []  # half a command: waiting for the rest
        else:
            assert isinstance(got[0], Rejected) and got[0].reason == reason, wire


def test_stray_bytes_are_dropped_and_a_command_after_them_parses() -> None:
    got = CommandParser().feed(b"xyz\r\n$?", 0.0)
    assert got == [Rejected("stray_byte", b"xyz\r\n"), Command(Kind.STATUS)] and got[0].weight == 5


def test_a_gap_of_more_than_2_ms_between_bytes_rejects_the_command() -> None:
    p = CommandParser()
    assert p.feed(b"$P0", 1.0) == [] and p.deadline_s() == pytest.approx(1.002)
    assert p.expire(1.0015) == []
    deadline = p.deadline_s()
    assert deadline is not None and p.expire(deadline) == [Rejected("gap", b"$P0")]  # at its deadline exactly
    assert p.deadline_s() is None
    # bytes 1 ms apart (9600 baud) are fine; a late byte after a gap is stray, and starts nothing
    assert p.feed(b"$P", 2.0) + p.feed(b"0", 2.001) + p.feed(b"05", 2.002) == [Command(Kind.PING, 5)]
    late = p.feed(b"$P0", 3.0) + p.feed(b"05", 3.01)
    assert late == [Rejected("gap", b"$P0"), Rejected("stray_byte", b"05")]
    # data bytes too: a slow payload is a gap
    assert p.feed(b"$B04ab", 4.0) + p.feed(b"cd", 4.5) == [Rejected("gap", b"$B04ab"), Rejected("stray_byte", b"cd")]


def test_a_payload_holding_dollar_hash_and_crlf_is_data() -> None:
    data = b"$P005#TO\r\nE\r\n$Q"
    got = CommandParser().feed(Command(Kind.BROADCAST, None, data).encode() + b"$?", 0.0)
    assert got == [Command(Kind.BROADCAST, None, data), Command(Kind.STATUS)]


def test_commands_refuse_what_the_unit_cannot_send() -> None:
    for bad in (lambda: Command(Kind.PING), lambda: Command(Kind.PING, 256), lambda: Command(Kind.STATUS, 1),
                lambda: Command(Kind.BROADCAST, None, b"x"), lambda: Command(Kind.UNICAST, 1, bytes(65)),
                lambda: Command(Kind.PING, 1, b"ab")):
        with pytest.raises(ValueError):
            bad()


REPLIES = [
    (Ack(Kind.PING, 5), b"$P005\r\n"), (Ack(Kind.BROADCAST, None, 5), b"$B05\r\n"),
    (Ack(Kind.UNICAST_ACK, 3, 2), b"$M00302\r\n"), (Quality(3), b"$C3\r\n"), (Quality(None), b"$C-\r\n"),
    (AddressSet(7), b"#A007\r\n"), (Status(7, 52429), b"#A007V52429\r\n"), (Range(5, 6401), b"#R005T06401\r\n"),
    (Timeout(), b"#TO\r\n"), (Received(b"V52429", 5), b"#B00506V52429\r\n"), (Received(b"$#\r\n"), b"#U04$#\r\n\r\n"),
    (Error(), b"E\r\n"),
]


@pytest.mark.parametrize(("reply", "wire"), REPLIES)
def test_each_reply_encodes_and_parses_as_the_unit_writes_it(reply: object, wire: bytes) -> None:
    assert reply.encode() == wire  # type: ignore[attr-defined]
    parser = ReplyParser()
    assert parser.feed(wire) == [reply] and parser.dropped == {}


def test_reply_values() -> None:
    assert Status(0, 52429).supply_v == pytest.approx(12.0, abs=1e-3)
    assert Range(5, 6401).range_m(1500.0) == pytest.approx(300.05, abs=0.01)


_COMMANDS = st.one_of(
    st.builds(Command, st.sampled_from([Kind.SET_ADDRESS, Kind.PING, Kind.VOLTAGE, Kind.TEST]), st.integers(0, 255)),
    st.builds(Command, st.sampled_from([Kind.STATUS, Kind.QUALITY])),
    st.builds(Command, st.just(Kind.BROADCAST), st.none(), st.binary(min_size=2, max_size=64)),
    st.builds(Command, st.sampled_from([Kind.UNICAST, Kind.UNICAST_ACK, Kind.ECHO]), st.integers(0, 255),
              st.binary(min_size=2, max_size=64)),
)


@settings(max_examples=150, deadline=None)
@given(st.lists(_COMMANDS, min_size=1, max_size=6), st.data())
def test_any_commands_split_anywhere_within_the_gap_parse_the_same(commands: list[Command],
                                                                   data: st.DataObject) -> None:
    wire = b"".join(c.encode() for c in commands)
    cuts = sorted(data.draw(st.lists(st.integers(0, len(wire)), max_size=8)))
    parser, got, t = CommandParser(), [], 0.0
    for a, b in zip([0, *cuts], [*cuts, len(wire)], strict=True):
        if b > a:
            got += parser.feed(wire[a:b], t)
            t += 0.001
    assert got == commands


_REPLY = st.one_of(
    st.builds(Ack, st.sampled_from([Kind.PING, Kind.VOLTAGE, Kind.TEST]), st.integers(0, 255)),
    st.builds(Ack, st.just(Kind.BROADCAST), st.none(), st.integers(2, 64)),
    st.builds(Ack, st.sampled_from([Kind.UNICAST, Kind.UNICAST_ACK, Kind.ECHO]), st.integers(0, 255),
              st.integers(2, 64)),
    st.builds(Quality, st.one_of(st.none(), st.integers(0, 8))), st.builds(AddressSet, st.integers(0, 255)),
    st.builds(Status, st.integers(0, 255), st.integers(0, 65535)),
    st.builds(Range, st.integers(0, 255), st.integers(0, 99999)), st.just(Timeout()), st.just(Error()),
    st.builds(Received, st.binary(min_size=2, max_size=64), st.one_of(st.none(), st.integers(0, 255))),
)


@settings(max_examples=150, deadline=None)
@given(st.lists(_REPLY, min_size=1, max_size=6))
def test_any_replies_round_trip_through_the_reply_parser(replies: list[object]) -> None:
    parser = ReplyParser()
    wire = b"".join(r.encode() for r in replies)  # type: ignore[attr-defined]
    assert [x for i in range(len(wire)) for x in parser.feed(wire[i:i + 1])] == replies and parser.dropped == {}


@settings(max_examples=200, deadline=None)
@given(st.lists(st.one_of(_REPLY.map(lambda r: r.encode()), st.binary(max_size=12)), min_size=1, max_size=8),
       st.data())
def test_replies_among_garbage_parse_the_same_whole_cut_anywhere_or_byte_by_byte(parts: list[bytes],
                                                                                 data: st.DataObject) -> None:
    """A payload is taken in one slice where a byte-wise walk would accept each of its bytes anyway: the
    replies and the drops by reason are those of the walk, however the bytes arrive."""
    wire = b"".join(parts)
    cuts = sorted(data.draw(st.lists(st.integers(0, len(wire)), max_size=8)))

    def parsed(pieces: list[bytes]) -> tuple[list[object], dict[str, int]]:
        parser = ReplyParser()
        return [r for piece in pieces for r in parser.feed(piece)], parser.dropped

    bytewise = parsed([wire[i:i + 1] for i in range(len(wire))])
    assert parsed([wire]) == bytewise
    assert parsed([wire[a:b] for a, b in zip([0, *cuts], [*cuts, len(wire)], strict=True)]) == bytewise
