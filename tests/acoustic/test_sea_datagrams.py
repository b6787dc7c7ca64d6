"""The sea's datagrams (acoustic/nanomodem/sea.py): what `vil modem --sea` and a GCS's simulated aMussels
say to each other over UDP. Every command survives its own encoding; anything else is refused with a
reason, never an uncaught exception; and `vil modem --sea` as a real process takes garbage and hostile
values on its socket, counts them by reason, and still carries a real report to its serial unit."""

from __future__ import annotations

import select
import signal
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from testkit import free_udp_port

from acoustic.nanomodem.driver import ModemDriver
from acoustic.nanomodem.emulator import FrameKind
from acoustic.nanomodem.ports import SerialPort
from acoustic.nanomodem.sea import HeardFrame, Move, Power, SeaClient, SeaError, Send, encode, parse
from missiontime.clocks import WallClock

VIL = Path(sys.executable).parent / "vil"
ADDRESS = st.integers(0, 255)
DATA = st.binary(min_size=0, max_size=64)


@given(st.one_of(
    st.builds(Send, ADDRESS, st.one_of(st.none(), ADDRESS), DATA),
    st.builds(HeardFrame, ADDRESS, st.sampled_from(list(FrameKind)), DATA),
    st.builds(Move, st.dictionaries(ADDRESS, st.tuples(*[st.floats(-1e5, 1e5).map(lambda v: round(v, 3))] * 3),
                                    min_size=1, max_size=20)),
    st.builds(Power, st.dictionaries(ADDRESS, st.booleans(), min_size=1, max_size=20)),
))
def test_every_command_survives_its_encoding(item: Send | HeardFrame | Move | Power) -> None:
    assert parse(encode(item)) == item


@settings(max_examples=2000)
@given(st.one_of(st.binary(max_size=200), st.text(max_size=120).map(str.encode),
                 st.lists(st.sampled_from(["S", "M", "H", "P", "0", "1", "256", "*", "-3", "nan", "inf", "zz", "ping",
                                           "", "5", "1e9", "0x10", "abc"]), max_size=9)
                 .map(lambda w: " ".join(w).encode())))
def test_anything_else_is_refused_with_a_reason(datagram: bytes) -> None:
    try:
        parse(datagram)
    except SeaError as exc:
        assert exc.reason in {"not_ascii", "address", "hex", "kind", "position", "power", "command"}


def test_vil_modem_counts_hostile_datagrams_and_still_carries_a_report() -> None:
    port = free_udp_port()
    proc = subprocess.Popen([str(VIL), "modem", "--nodes", "5@20,0,3", "--sea", f"udp:127.0.0.1:{port}"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    try:
        ready, _, _ = select.select([proc.stdout], [], [], 60.0)
        assert ready, "vil modem printed no device within the bound"
        device = proc.stdout.readline().strip()
        hostile = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        for datagram in (b"\xff\xfe", b"S 999 * 00", b"S 5 * zz", b"M 5 nan 0 0", b"H 5 ping 00", b"Q", b"S 7 * 00",
                         b"P 5 2", b"P 7 0"):
            hostile.sendto(datagram, ("127.0.0.1", port))
        hostile.close()
        sea = SeaClient("127.0.0.1", port)
        driver = ModemDriver(SerialPort(device), WallClock())
        sea.move([5], np.array([[20.0, 0.0, 3.0]]))
        sea.send(5, b"a report", 0)
        heard = []
        deadline = WallClock()
        while not heard and deadline.time() < 20.0:
            heard = driver.received()
            deadline.sleep(0.05)
        assert [(p.data, p.source) for p in heard] == [(b"a report", None)]  # a unicast to this unit
        driver.port.close()
        sea.close()
    finally:
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=30)
    assert proc.returncode == 0
    for reason in ("sea_not_ascii 1", "sea_address 1", "sea_hex 1", "sea_position 1", "sea_not_a_command 1",
                   "sea_command 1", "sea_unknown_unit_or_payload 1", "sea_power 1", "power_unknown_unit 1"):
        assert reason in err, (reason, err)
