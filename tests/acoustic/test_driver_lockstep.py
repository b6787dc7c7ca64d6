"""The driver against the emulator over an in-process pipe on a virtual clock: every command, its
answer from the water, and the bounded waits' outcomes."""

from __future__ import annotations

import numpy as np
import pytest

from acoustic.airtime import RANGE_TICK_S
from acoustic.nanomodem.driver import ACK_WAIT_S, ModemDriver, Outcome
from acoustic.nanomodem.emulator import ModemEmulator, RemoteUnit
from acoustic.nanomodem.lockstep import Attached, attach
from acoustic.nanomodem.ports import pipe
from acoustic.nanomodem.replies import AddressSet, Quality, Range, Received, Status
from acoustic.params import AcousticParams
from missiontime.clocks import VirtualClock

NEAR, FAR = RemoteUnit(5, (300.0, 0.0, 5.0), supply_v=11.5), RemoteUnit(9, (5000.0, 0.0, 5.0))


def _rig(seed: int = 1) -> tuple[ModemDriver, ModemEmulator, VirtualClock]:
    driver, attached, clock = _attached(seed)
    return driver, attached.core, clock


def _attached(seed: int = 1) -> tuple[ModemDriver, Attached, VirtualClock]:
    clock = VirtualClock()
    host, modem = pipe()
    core = ModemEmulator(AcousticParams(), (NEAR, FAR), np.random.default_rng(seed))
    return ModemDriver(host, clock), attach(core, modem, clock), clock


def test_status_address_and_quality() -> None:
    driver, core, _ = _rig()
    status = driver.status()
    assert status.ok and isinstance(status.reply, Status) and status.reply.supply_v == pytest.approx(12.0, abs=1e-3)
    assert driver.set_address(42).reply == AddressSet(42) and core.address == 42
    assert driver.quality().reply == Quality(None)  # nothing heard yet


def test_ping_gives_the_range_and_an_unreachable_unit_times_out_after_4_s() -> None:
    driver, _, clock = _rig()
    result = driver.ping(5)
    assert result.ok and isinstance(result.reply, Range)
    true_range = float(np.linalg.norm(NEAR.position_m))
    assert abs(result.reply.range_m(1500.0) - true_range) <= 1500.0 * RANGE_TICK_S
    assert clock.time() == pytest.approx(0.105 * 2 + 2 * true_range / 1500.0, abs=0.011)  # both legs, polls
    t0 = clock.time()
    lost = driver.ping(9)
    assert lost.outcome is Outcome.TIMEOUT and clock.time() - t0 == pytest.approx(4.0, abs=0.011)
    assert driver.quality().reply == Quality(0)  # the reply from 300 m: no byte wrong


def test_unicast_with_ack_voltage_echo_and_packets_heard() -> None:
    driver, attached, clock = _attached()
    core = attached.core
    assert driver.unicast_ack(5, b"surface!").ok
    assert [(a, f.data) for _, a, f in core.heard.entries] == [(5, b"surface!")]
    volts = driver.voltage(5)
    assert volts.ok and isinstance(volts.reply, Received) and volts.reply.data == b"V50244"  # 11.5 V
    assert driver.echo(5, b"$#\r\n").ok
    clock.sleep(2.0)  # the echo back: this unit cannot hear it while sending the next
    assert driver.broadcast(b"hello all").ok and driver.unicast(5, b"hi").ok
    assert driver.test(5).ok
    clock.sleep(3.0)
    attached.remote_send(5, b"status 31 bytes")
    clock.sleep(2.0)
    assert driver.received() == [Received(b"$#\r\n"), Received(b"status 31 bytes", 5)]
    assert driver.dropped == {}
    assert [f.data for _, a, f in core.heard.entries if a == 5][-3:] == [b"hello all", b"hi", b""]


def test_a_unit_without_power_hears_and_answers_nothing_until_it_has_power_again() -> None:
    driver, attached, clock = _attached()
    core = attached.core
    attached.power({5: False, 77: False})  # 77: no such unit, counted
    assert core.unpowered == {5} and core.counts["power_unknown_unit"] == 1
    t0 = clock.time()
    assert driver.ping(5).outcome is Outcome.TIMEOUT and clock.time() - t0 == pytest.approx(4.0, abs=0.011)
    assert driver.unicast_ack(5, b"surface!").outcome is Outcome.TIMEOUT
    assert core.heard.total == 0 and core.counts["remote_unpowered"] == 2
    attached.power({5: True})
    assert driver.ping(5).ok and driver.unicast_ack(5, b"surface!").ok
    assert [(a, f.data) for _, a, f in core.heard.entries] == [(5, b""), (5, b"surface!")]


def test_the_unit_answering_E_ends_the_wait_as_error_and_silence_as_no_reply() -> None:
    clock = VirtualClock()
    host, modem = pipe()
    driver = ModemDriver(host, clock)
    answers = [b"E\r\n", b""]

    def unit(_now_us: int) -> None:
        if modem.read():
            modem.write(answers.pop(0) if answers else b"")

    clock.scheduler.every(0.001, unit, "a unit that refuses, then says nothing")
    assert driver.status().outcome is Outcome.ERROR
    t0 = clock.time()
    assert driver.status().outcome is Outcome.NO_REPLY and clock.time() - t0 == pytest.approx(ACK_WAIT_S, abs=0.006)
    modem.write(b"E\r\n")  # late: the next command does not take it for its own
    assert driver.status().outcome is Outcome.NO_REPLY and driver.dropped == {"unexpected_reply": 1}


def test_a_seed_repeats_the_water_exactly() -> None:
    def session(seed: int) -> list[object]:
        driver, core, clock = _rig(seed)
        core.medium.move(np.array([[0, 0, 0], [1700.0, 0, 5.0], [5000.0, 0, 5.0]]))  # where packets get lost
        return [driver.ping(5).outcome for _ in range(12)] + [clock.time()]

    first = session(3)
    assert session(3) == first
    assert Outcome.TIMEOUT in first and Outcome.REPLIED in first


def test_the_emulator_runs_to_any_instant_through_a_slow_command_and_a_timeout() -> None:
    core = ModemEmulator(AcousticParams(), (NEAR, FAR), np.random.default_rng(1))
    core.from_host(b"$P0", 1.0)
    due = core.next_due_s()
    assert due == pytest.approx(1.002)
    assert core.advance(due) == b"E\r\n" and core.next_due_s() is None  # at its deadline exactly
    core.from_host(b"$P009", 2.0)
    assert core.advance(5.999) == b"$P009\r\n" and core.advance(6.0) == b"#TO\r\n"


def test_a_ping_queued_behind_broadcasts_times_out_from_its_own_transmission() -> None:
    """Four 64-byte broadcasts (4.4 s on the water) then a ping to a unit 300 m away: the ping goes out
    when the transmitter is free, and its range comes back (a deadline from the command's arrival
    answered #TO before the ping was even sent)."""
    core = ModemEmulator(AcousticParams(), (NEAR, FAR), np.random.default_rng(1))
    for i in range(4):
        core.from_host(b"$B64" + bytes([65 + i]) * 64, 0.0)
    core.from_host(b"$P005", 0.0)
    out, t = b"", 0.0
    while (due := core.next_due_s()) is not None and t < 30.0:
        t = due
        out += core.advance(t)
    assert b"#TO" not in out and b"#R005T" in out, out
    assert core.counts.get("timeout", 0) == 0


def test_an_idle_emulator_costs_the_clock_nothing() -> None:
    """No traffic: the emulator's task is not ticking (a lockstep mission of hours pays nothing for it)."""
    driver, attached, clock = _attached()
    assert driver.ping(5).ok
    clock.sleep(1.0)
    assert not attached.task.active  # nothing due: off the queue until a byte or a packet needs it
    calls = []
    clock.scheduler.every(600.0, lambda now_us: calls.append(now_us), "a slow task", start_us=clock.now_us)
    clock.sleep(3600.0)
    assert len(calls) == 7 and not attached.task.active and driver.status().ok


def test_packets_nobody_reads_are_kept_to_a_bound_and_the_overflow_counted() -> None:
    from acoustic.nanomodem.driver import QUEUE_MAX

    host, modem = pipe()
    driver = ModemDriver(host, VirtualClock())
    modem.write(b"#B00503abc\r\n" * (QUEUE_MAX + 10))
    driver.poll()
    assert len(driver.inbox) == QUEUE_MAX and driver.dropped["queue_full"] >= 10
    assert driver.received()[-1].data == b"abc"
