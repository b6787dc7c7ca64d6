"""Hostile bytes (issue 21): garbage, half commands, binary payloads holding $, # and CR LF, bursts
faster than 9600 baud, a device that vanishes; for the emulator and for the driver. Nothing crashes;
what does not parse is dropped and counted by reason."""

from __future__ import annotations

import os
import select
import subprocess
import sys
import tty
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from acoustic.nanomodem.driver import ModemDriver, Outcome
from acoustic.nanomodem.emulator import ModemEmulator, RemoteUnit
from acoustic.nanomodem.host_commands import CommandParser
from acoustic.nanomodem.lockstep import attach
from acoustic.nanomodem.ports import SerialPort, pipe
from acoustic.nanomodem.replies import Range, Received, ReplyParser, Status, Timeout
from acoustic.params import AcousticParams
from missiontime.clocks import VirtualClock, WallClock

NEAR = RemoteUnit(5, (300.0, 0.0, 5.0))
VIL = Path(sys.executable).parent / "vil"


def _core() -> ModemEmulator:
    return ModemEmulator(AcousticParams(), (NEAR,), np.random.default_rng(1))


# ---- the emulator

def test_garbage_is_dropped_by_reason_and_each_invalid_command_answers_E() -> None:
    core = _core()
    rng = np.random.default_rng(5)
    garbage = rng.integers(0, 256, 20_000, dtype=np.uint8).tobytes()
    core.from_host(garbage, 0.0)
    out = core.advance(0.0) + core.advance(100.0)
    rejected = {k: v for k, v in core.counts.items() if k not in ("command", "timeout", "heard")}
    assert rejected["stray_byte"] > 10_000 and sum(rejected.values()) > rejected["stray_byte"]
    refusals = sum(v for k, v in rejected.items() if k != "stray_byte")
    assert out.count(b"E\r\n") >= refusals  # (E may also sit inside a result's data)
    core.from_host(b"$?", 200.0)
    assert core.advance(200.0) == b"#A000V52429\r\n"  # and it still works


def test_half_commands_answer_E_at_their_gap_and_what_follows_parses() -> None:
    core = _core()
    for k, half in enumerate((b"$", b"$U005", b"$B10abc", b"$M0050", b"$E00502x")):
        core.from_host(half, float(k))
        assert core.advance(k + 0.5) == b"E\r\n", half
    assert core.counts["gap"] == 5


def test_binary_payloads_holding_the_protocols_own_bytes_travel_intact() -> None:
    core = _core()
    payload = b"$P005#TO\r\nE\r\n$B02\x00\xff"
    core.from_host(b"$U005" + f"{len(payload):02d}".encode() + payload, 0.0)
    core.advance(10.0)
    assert [f.data for _, _, f in core.heard.entries] == [payload]
    core.from_host(b"$E005" + f"{len(payload):02d}".encode() + payload, 20.0)
    n = f"{len(payload):02d}".encode()
    assert core.advance(30.0) == b"$E005" + n + b"\r\n#U" + n + payload + b"\r\n"


def test_a_burst_far_faster_than_9600_baud_is_answered_in_order() -> None:
    core = _core()
    core.from_host(b"$?" * 500 + b"$A001" + b"$?" * 500, 0.0)
    assert core.advance(0.0) == b"#A000V52429\r\n" * 500 + b"#A001\r\n" + b"#A001V52429\r\n" * 500


def test_a_host_writing_faster_than_the_water_carries_is_refused_not_queued_without_bound() -> None:
    core = _core()
    core.from_host(b"$B64" + bytes(64), 0.0)
    for k in range(1, 11):
        core.from_host(b"$B64" + bytes(64), k * 0.01)  # 1.1 s packets: four queue behind the first (4.5 s), then E
    out = core.advance(0.2)
    assert out == b"$B64\r\n" * 5 + b"E\r\n" * 6 and core.counts["busy"] == 6


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.binary(max_size=80), st.floats(0.0, 0.01)), max_size=12))
def test_any_chunks_at_any_pace_never_raise(chunks: list[tuple[bytes, float]]) -> None:
    core, t = _core(), 0.0
    for data, dt in chunks:
        t += dt
        core.advance(t)
        core.from_host(data, t)
    core.advance(t + 10.0)
    assert sum(core.counts.values()) >= 0 and core.next_due_s() is None


def test_vil_modem_on_a_device_that_vanishes_ends_with_one_line() -> None:
    master, slave = os.openpty()
    tty.setraw(slave)
    name = os.ttyname(slave)
    proc = subprocess.Popen([str(VIL), "modem", "--device", name, "--nodes", "5@300,0,5"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    ready, _, _ = select.select([proc.stdout], [], [], 60.0)
    assert ready and proc.stdout.readline().strip() == name
    os.write(master, b"$?")
    ready, _, _ = select.select([master], [], [], 30.0)
    assert ready and os.read(master, 100) == b"#A000V52429\r\n"
    os.close(master)
    os.close(slave)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 1
    assert f"vil modem: {name}: gone" in err and "Traceback" not in err


# ---- the driver

def test_the_reply_parser_drops_garbage_and_half_replies_by_reason_and_keeps_the_rest() -> None:
    parser = ReplyParser()
    got = parser.feed(b"\x00junk#R005T0#TO\r\n#A0x1\r\n$C9\r\n#U04$#\r\n\r\n#B00502ok\rX#A001V52429\r\n")
    assert got == [Timeout(), Received(b"$#\r\n"), Status(1, 52429)]
    # stray: \x00 j u n k, the 1 and CR LF after #A0x, the CR LF after $C9
    assert parser.dropped == {"stray_byte": 10, "bad_digit": 2, "bad_value": 1, "bad_terminator": 1}


def test_a_burst_of_a_thousand_replies_in_one_read() -> None:
    parser = ReplyParser()
    burst = b"".join(Range(5, k).encode() + Received(b"\r\n$#", 7).encode() for k in range(1000))
    got = parser.feed(burst)
    assert got[::2] == [Range(5, k) for k in range(1000)] and len(got) == 2000 and parser.dropped == {}


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=300))
def test_any_bytes_from_the_modem_never_raise_and_are_all_accounted(data: bytes) -> None:
    parser = ReplyParser()
    got = parser.feed(data)
    parser.cut("truncated")
    assert len(got) + sum(parser.dropped.values()) >= (1 if data else 0)


def test_a_pipe_that_closes_ends_every_wait_as_closed() -> None:
    clock = VirtualClock()
    host, modem = pipe()
    core = ModemEmulator(AcousticParams(), (NEAR,), np.random.default_rng(1))
    attach(core, modem, clock)
    driver = ModemDriver(host, clock)
    assert driver.status().ok
    modem.write(b"#R005T0")  # half a reply, then the other end goes
    modem.close()
    assert driver.ping(5).outcome is Outcome.CLOSED
    assert driver.status().outcome is Outcome.CLOSED and driver.received() == []
    assert driver.closed_reason is not None and driver.dropped == {"truncated": 1}


def test_a_real_serial_device_that_vanishes_ends_the_driver_cleanly() -> None:
    master, slave = os.openpty()
    tty.setraw(slave)
    driver = ModemDriver(SerialPort(os.ttyname(slave)), WallClock())
    os.write(master, b"#A000V52429\r\n")
    assert driver.wait_for(lambda r: isinstance(r, Status), 5.0).ok
    os.close(master)
    os.close(slave)
    assert driver.status().outcome is Outcome.CLOSED
    assert driver.ping(5).outcome is Outcome.CLOSED and "Input/output error" in (driver.closed_reason or "")
    driver.port.close()


def test_a_device_that_cannot_be_opened_is_one_line() -> None:
    from acoustic.nanomodem.ports import PortClosed

    with pytest.raises(PortClosed, match="cannot open"):
        SerialPort("/dev/nonexistent-modem")
    assert CommandParser().feed(b"", 0.0) == []


def test_a_short_fuzz_run_of_random_and_mutated_inputs_raises_nothing() -> None:
    """bench/fuzz_modem.py's generator, briefly (the bench runs 120,000 inputs)."""
    from serial_fuzz import SerialFuzz

    fuzz = SerialFuzz(11)
    for i in range(600):
        fuzz.feed(fuzz.random_input() if i % 2 == 0 else fuzz.mutated_input())
    assert fuzz.command_counts["stray_byte"] > 0 and fuzz.replies.dropped["stray_byte"] > 0
    assert fuzz.emulator.counts["command"] > 0  # mutated inputs still carry valid commands
