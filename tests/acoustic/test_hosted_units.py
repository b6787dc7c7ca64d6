"""Several units on host serial lines on one water: the GCS's unit and an aPad's own, each with its
own driver over its own pipe, on one virtual clock."""

from __future__ import annotations

import numpy as np
import pytest

from acoustic.airtime import RANGE_TICK_S
from acoustic.nanomodem.driver import ModemDriver
from acoustic.nanomodem.emulator import FrameKind, ModemEmulator, RemoteUnit
from acoustic.nanomodem.lockstep import attach
from acoustic.nanomodem.ports import pipe
from acoustic.nanomodem.replies import Range, Status
from acoustic.params import AcousticParams
from missiontime.clocks import VirtualClock

MUSSEL = RemoteUnit(7, (820.0, 0.0, 3.0))
APAD_UNIT = RemoteUnit(200, (800.0, 0.0, 0.5), supply_v=14.0)  # the aPad 20 m from the aMussel, 800 m out


def _range_m(a: tuple[float, float, float], b: tuple[float, float, float]) -> float:
    return float(np.linalg.norm(np.subtract(a, b)))


def _rig() -> tuple[ModemDriver, ModemDriver, ModemEmulator, VirtualClock]:
    clock = VirtualClock()
    gcs_host, gcs_modem = pipe()
    apad_host, apad_modem = pipe()
    core = ModemEmulator(AcousticParams(), (MUSSEL,), np.random.default_rng(1), position_m=(0.0, 0.0, 0.5),
                         hosted=(APAD_UNIT,))
    attach(core, gcs_modem, clock, hosted=(apad_modem,))
    return ModemDriver(gcs_host, clock), ModemDriver(apad_host, clock), core, clock


def test_a_hosted_unit_pings_and_calls_up_from_its_own_place_and_only_it_hears_the_answers() -> None:
    gcs, apad, core, _ = _rig()
    status = apad.status()
    assert isinstance(status.reply, Status) and status.reply.address == 200
    assert status.reply.supply_v == pytest.approx(14.0, abs=1e-3)
    ping = apad.ping(7)
    assert ping.ok and isinstance(ping.reply, Range)
    assert abs(ping.reply.range_m(1500.0) - _range_m(APAD_UNIT.position_m, MUSSEL.position_m)) <= 1500.0 * RANGE_TICK_S
    call_up = apad.unicast_ack(7, b"up")
    assert call_up.ok
    assert [(a, f.kind, f.source, f.data) for _, a, f in core.heard.entries] == [
        (7, FrameKind.PING, 200, b""), (7, FrameKind.UNICAST_ACK, 200, b"up")]
    assert gcs.received() == [] and gcs.dropped == {}  # the answers were the aPad unit's, not the GCS's


def test_the_gcs_unit_still_ranges_from_the_shore_beside_a_hosted_one() -> None:
    gcs, _, _, _ = _rig()
    ping = gcs.ping(7)
    assert ping.ok and isinstance(ping.reply, Range)
    assert abs(ping.reply.range_m(1500.0) - _range_m((0.0, 0.0, 0.5), MUSSEL.position_m)) <= 1500.0 * RANGE_TICK_S


def test_hosted_units_move_with_the_remote_units_and_their_addresses_are_checked() -> None:
    _, apad, core, _ = _rig()
    core.move_remotes([200], np.array([[700.0, 0.0, 0.5]]))  # the aPad went 100 m further from the aMussel
    ping = apad.ping(7)
    moved = _range_m((700.0, 0.0, 0.5), MUSSEL.position_m)
    assert isinstance(ping.reply, Range) and abs(ping.reply.range_m(1500.0) - moved) <= 1500.0 * RANGE_TICK_S
    with pytest.raises(ValueError, match="must differ"):
        ModemEmulator(AcousticParams(), (MUSSEL,), np.random.default_rng(1), hosted=(RemoteUnit(7, (0.0, 0.0, 0.0)),))
    clock = VirtualClock()
    with pytest.raises(ValueError, match="1 hosted units, 0 ports"):
        attach(ModemEmulator(AcousticParams(), (MUSSEL,), np.random.default_rng(1), hosted=(APAD_UNIT,)),
               pipe()[1], clock)
