"""The channel model against published values and its own rules: delay, loss, SNR, PER, the medium."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from acoustic.airtime import airtime_s, data_airtime_s
from acoustic.channel import Medium, Outcome
from acoustic.params import AcousticParams
from acoustic.per import SNR_GRID_DB, bfsk_bit_error, success_lookup, success_probability
from acoustic.propagation import delay_s, noise_level_db, snr_db, thorp_db_per_km, transmission_loss_db

P = AcousticParams()


def test_thorp_absorption_at_published_values() -> None:
    # Thorp's formula in dB/km (Stojanovic 2007, ns-3 UanPropModelThorp): 1.19 dB/km at 10 kHz,
    # 7.39 at 28 kHz (the nanomodem's band centre, NOTES.md: about 7.4).
    assert thorp_db_per_km(10.0) == pytest.approx(1.187, abs=1e-3)
    assert thorp_db_per_km(28.0) == pytest.approx(7.392, abs=1e-3)
    assert np.all(np.diff(thorp_db_per_km(np.arange(1.0, 100.0))) > 0)


def test_loss_noise_and_snr_as_newcastles_budget() -> None:
    # TL = 20 log10 R + a(f) R/1000; NL = 50 + 10 log10 8000; SNR = 168 - TL - NL.
    assert transmission_loss_db(1000.0, P) == pytest.approx(60.0 + 7.392, abs=1e-3)
    assert transmission_loss_db(0.2, P) == pytest.approx(transmission_loss_db(1.0, P))  # no gain inside 1 m
    assert noise_level_db(P) == pytest.approx(50.0 + 39.031, abs=1e-3)
    assert snr_db(1000.0, P) == pytest.approx(168.0 - 67.392 - 89.031, abs=1e-2)
    practical = replace(P, spreading_k=1.5)
    assert transmission_loss_db(1000.0, practical) == pytest.approx(45.0 + 7.392, abs=1e-3)
    assert delay_s(1500.0, P) == pytest.approx(1.0)
    assert delay_s(1500.0, replace(P, sound_speed_mps=1480.0)) == pytest.approx(1500.0 / 1480.0)


def test_airtime_by_the_modems_formula() -> None:
    assert airtime_s(0) == pytest.approx(0.105)  # a ping or command packet
    assert airtime_s(64) == pytest.approx(1.105)  # NOTES.md: 1.105 s for 64 bytes
    assert airtime_s(2) == pytest.approx(0.105 + 18 * 0.0125)
    assert data_airtime_s([2, 16, 64]) == pytest.approx([0.33, 0.505, 1.105])
    for bad in (1, 65, -3):
        with pytest.raises(ValueError, match=r"2\.\.64"):
            airtime_s(bad)


def test_bfsk_bit_error_is_proakis() -> None:
    # Noncoherent BFSK, Pb = 1/2 exp(-Eb/N0 / 2): 3.37e-3 at 10 dB, 1/2 at 0 (linear 0).
    assert bfsk_bit_error(10.0) == pytest.approx(0.5 * np.exp(-5.0))
    assert bfsk_bit_error(0.0) == pytest.approx(0.5)


def test_per_curve_has_newcastles_shape() -> None:
    """PER 1 below about -3 dB and about 0 above 8 dB (Newcastle's starter simulation); falling with SNR,
    and a 64-byte packet fails sooner than a 16-byte one."""
    snr = np.linspace(-9.0, 12.0, 43)
    for n in (16, 64):
        ok = success_probability(snr, n, P)
        assert np.all(np.diff(ok) >= 0)
        assert success_probability(-3.0, n, P) < 0.05
        assert success_probability(8.0, n, P) > 0.94
    assert np.all(success_probability(snr, 64, P) <= success_probability(snr, 16, P) + 1e-12)
    # without fading the fall is a waterfall: from 5 % to 95 % within 3 dB (with fading: over 8 dB)
    fine = np.linspace(-10.0, 15.0, 251)
    for params, lo, hi in ((replace(P, fading_m=0.0), 0.0, 3.0), (P, 8.0, 14.0)):
        ok = success_probability(fine, 16, params)
        width = fine[np.argmax(ok > 0.95)] - fine[np.argmax(ok > 0.05)]
        assert lo < width < hi


def test_the_channels_table_is_the_curve_at_its_grid_and_close_between() -> None:
    """The table the channel reads (one sliding sum over a fine grid) is the fading average taken point by
    point, for pings and data, Rayleigh and m = 3 fading and none; between its points within 1e-4 with
    fading and 1e-3 without (the unfaded waterfall is steeper)."""
    between = SNR_GRID_DB[:-1] + 0.5 * np.diff(SNR_GRID_DB)
    for fading_m, bound in ((0.0, 1e-3), (1.0, 1e-4), (3.0, 1e-4)):
        params = replace(P, fading_m=fading_m)
        for n in (0, 16, 64):
            exact = success_probability(SNR_GRID_DB, n, params)
            assert np.abs(success_lookup(SNR_GRID_DB, n, params) - exact).max() < 1e-9
            assert np.abs(success_lookup(between, n, params) - success_probability(between, n, params)).max() < bound


def test_delivery_against_range() -> None:
    """Near 1 to about 1.3 km and near 0 by 2.5 km (NOTES.md: Newcastle's simulation)."""
    ok = success_probability(snr_db(np.array([500.0, 1000.0, 1300.0, 2500.0]), P), 16, P)
    assert ok[0] > 0.999 and ok[1] > 0.99 and ok[2] > 0.95 and ok[3] < 0.01


def _medium(positions: list[tuple[float, float, float]], seed: int = 1, **kw: float) -> Medium:
    return Medium(replace(P, **kw), np.array(positions, dtype=float), np.random.default_rng(seed))


def test_a_packet_arrives_after_its_delay_and_lasts_its_airtime() -> None:
    m = _medium([(0, 0, 0), (750, 0, 0), (0, 1000, 0)])
    tx = m.transmit(0, 10.0, 16, b"x")
    assert m.next_decision_s() == pytest.approx(10.0 + 0.5 + 0.505)
    assert m.settle(10.9) == []
    first = m.settle(11.005 + 1e-9)
    assert [(r.receiver, r.outcome) for r in first] == [(1, Outcome.DELIVERED)]
    assert first[0].start_s == pytest.approx(10.5) and first[0].transmission is tx
    second = m.settle(100.0)
    assert [(r.receiver, r.outcome, round(r.start_s, 9)) for r in second] == [(2, Outcome.DELIVERED, 10.666666667)]
    assert m.settle(200.0) == [] and m.next_decision_s() is None


def test_overlapping_packets_collide_at_the_receiver_and_both_are_lost() -> None:
    m = _medium([(0, 0, 0), (300, 0, 0), (-300, 0, 0)])
    m.transmit(1, 0.0, 64)
    m.transmit(2, 0.5, 64)  # arrives at node 0 while the first is still arriving
    got = m.settle(10.0)
    at_0 = [(r.transmission.sender, r.outcome) for r in got if r.receiver == 0]
    assert at_0 == [(1, Outcome.COLLISION), (2, Outcome.COLLISION)]
    # apart in time: both heard
    m2 = _medium([(0, 0, 0), (300, 0, 0), (-300, 0, 0)])
    m2.transmit(1, 0.0, 64)
    m2.transmit(2, 1.5, 64)
    assert [r.outcome for r in m2.settle(10.0) if r.receiver == 0] == [Outcome.DELIVERED] * 2


def test_a_far_weak_packet_does_not_spoil_a_near_one() -> None:
    m = _medium([(0, 0, 0), (100, 0, 0), (9000, 0, 0)])
    m.transmit(1, 0.0, 16)
    m.transmit(2, -5.9, 16)  # 9 km away: arrives at node 0 at 0.1 s, below the interference level there
    assert [r.outcome for r in m.settle(20.0) if r.receiver == 0] == [Outcome.DELIVERED]


def test_half_duplex_a_node_sending_hears_nothing() -> None:
    m = _medium([(0, 0, 0), (150, 0, 0)])
    m.transmit(0, 0.0, 64)  # node 0 busy 0 .. 1.105 s
    m.transmit(1, 0.0, 16)  # arrives at node 0 at 0.1 s: lost there; node 1 also sending when 0's arrives
    outcomes = {(r.transmission.sender, r.receiver): r.outcome for r in m.settle(5.0)}
    assert outcomes == {(1, 0): Outcome.HALF_DUPLEX, (0, 1): Outcome.HALF_DUPLEX}
    assert m.counts["half_duplex"] == 2
    assert m.busy_until_s(0) == -np.inf  # pruned once nothing can overlap it


def test_many_receivers_deliver_at_the_curves_rate_and_a_seed_repeats_them() -> None:
    n = 1500
    rng = np.random.default_rng(0)
    angle = rng.uniform(0, 2 * np.pi, n)
    positions = np.column_stack([1700 * np.cos(angle), 1700 * np.sin(angle), np.zeros(n)])
    positions = np.vstack([[0.0, 0.0, 0.0], positions])

    def run(seed: int) -> np.ndarray:
        m = Medium(P, positions, np.random.default_rng(seed))
        m.transmit(0, 0.0, 64)
        return np.array([r.outcome is Outcome.DELIVERED for r in m.settle(10.0)])

    delivered = run(7)
    p = float(success_probability(snr_db(1700.0, P), 64, P))
    assert 0.1 < p < 0.9 and len(delivered) == n
    assert abs(delivered.mean() - p) < 4 * np.sqrt(p * (1 - p) / n)
    assert np.array_equal(run(7), delivered) and not np.array_equal(run(8), delivered)


def test_out_of_range_nodes_hear_nothing_and_moves_apply_to_later_packets() -> None:
    m = _medium([(0, 0, 0), (20_000, 0, 0)])
    m.transmit(0, 0.0, 16)
    assert m.settle(100.0) == [] and m.next_decision_s() is None
    m.move(np.array([[0, 0, 0], [200, 0, 0]], dtype=float))
    assert [r.outcome for r in m.settle(100.0)] == []
    m.transmit(0, 100.0, 16)
    got = m.settle(200.0)
    assert [r.receiver for r in got] == [1] and got[0].range_m == pytest.approx(200.0)
    with pytest.raises(ValueError, match="shape"):
        m.move(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="no node"):
        m.transmit(5, 0.0, 16)
