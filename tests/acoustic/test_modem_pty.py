"""Must show (issue 21): `vil modem` as a real process on a real pty, driven with raw bytes exactly as
the unit's protocol writes them, through pyserial; and the driver over the same pty."""

from __future__ import annotations

import signal
import subprocess
import time
from collections.abc import Iterator

import pytest
import serial
from testkit import start_vil_modem

from acoustic.nanomodem.driver import ModemDriver, Outcome
from acoustic.nanomodem.ports import SerialPort
from acoustic.nanomodem.replies import Range, Received
from missiontime.clocks import WallClock


@pytest.fixture(scope="module")
def modem() -> Iterator[tuple[str, subprocess.Popen[str]]]:
    """`vil modem` with unit 5 at 300 m (5 m deep) and unit 9 at 5 km, out of reach."""
    device, proc = start_vil_modem("--nodes", "5@300,0,5", "9@5000,0,5", "--seed", "1")
    yield device, proc
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 0 and "vil modem: stopped;" in err


def _expect(port: serial.Serial, wire: bytes, bound_s: float = 10.0) -> bytes:
    """Exactly `wire` from the unit (read until that many bytes or the bound)."""
    port.timeout = bound_s
    got = port.read(len(wire))
    assert got == wire
    return got


def test_the_units_protocol_byte_for_byte(modem: tuple[str, subprocess.Popen[str]]) -> None:
    device, _ = modem
    with serial.Serial(device, 9600, bytesize=8, parity="N", stopbits=1, timeout=10) as port:
        port.write(b"$?")
        _expect(port, b"#A000V52429\r\n")  # 12 V = 52429 x 15 / 65536
        port.write(b"$A007")
        _expect(port, b"#A007\r\n")
        port.write(b"$P005")
        _expect(port, b"$P005\r\n")
        _expect(port, b"#R005T06401\r\n")  # 300.04 m / (1500 m/s x 3.125e-5 s)
        port.write(b"$B05hello")
        _expect(port, b"$B05\r\n")
        port.write(b"$U00504$#\r\n")  # a payload holding $, # and CR LF
        _expect(port, b"$U00504\r\n")
        time.sleep(0.6)  # let the unicast leave the water before the next packet (half duplex)
        port.write(b"$M00503abc")
        _expect(port, b"$M00503\r\n")
        _expect(port, b"#R005T06401\r\n")  # delivered: the acknowledgement's round trip
        port.write(b"$Q")
        _expect(port, b"$C0\r\n")  # the acknowledgement from 300 m decoded with no byte wrong
        port.write(b"$V005")
        _expect(port, b"$V005\r\n")
        _expect(port, b"#B00506V52429\r\n")
        port.write(b"$X12")  # no such command
        _expect(port, b"E\r\n")
        port.write(b"$P2x5")  # not a number
        _expect(port, b"E\r\n")
        port.write(b"$P0")  # too slow: 50 ms before the rest
        time.sleep(0.05)
        port.write(b"05")
        _expect(port, b"E\r\n")
        port.write(b"$?")  # the late "05" was dropped, not taken as a command
        _expect(port, b"#A007V52429\r\n")
        t0 = time.monotonic()  # before the write: a stall of this process can only lengthen what it sees
        port.write(b"$P009")  # 5 km: nobody answers
        _expect(port, b"$P009\r\n")
        _expect(port, b"#TO\r\n", bound_s=30.0)
        assert time.monotonic() - t0 >= 3.9  # the unit's own 4 s (a lower bound: it cannot come early)


def test_the_driver_over_the_same_pty(modem: tuple[str, subprocess.Popen[str]]) -> None:
    device, _ = modem
    driver = ModemDriver(SerialPort(device), WallClock())
    try:
        ping = driver.ping(5)
        assert ping.ok and isinstance(ping.reply, Range) and ping.reply.range_m(1500.0) == pytest.approx(300.0, abs=0.1)
        assert driver.echo(5, b"$#\r\nE\r\n").ok
        deadline = time.monotonic() + 10.0
        heard: list[Received] = []
        while not heard and time.monotonic() < deadline:
            heard = driver.received()
            time.sleep(0.05)
        assert heard == [Received(b"$#\r\nE\r\n")] and driver.dropped == {}
        assert driver.status().outcome is Outcome.REPLIED
    finally:
        driver.port.close()
