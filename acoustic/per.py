"""Packet success from SNR and payload size: the nanomodem's coded packet over a faded channel.

Three published pieces, composed:

1. Bit errors of noncoherent binary FSK in white Gaussian noise, Pb = 1/2 exp(-Eb/N0 / 2)
   (Proakis and Salehi, Digital Communications, 5th ed., section 4.5), with Eb/N0 the band's SNR
   times the spread-spectrum processing gain B/R (8000 Hz / 640 bit/s, 11 dB).
2. The modem's code: a data packet carries n + 16 coded bytes, and up to 8 wrong bytes are corrected
   (nanomodem v3 user guide; a bounded-distance byte decoder, as Reed-Solomon codes are): a packet
   is lost when more than 8 of its n + 16 bytes are wrong, so longer payloads fail sooner.
3. Block fading: each packet sees the mean SNR times a Nakagami-m power draw, Gamma(m, 1/m)
   (Nakagami 1960; m = 1 is Rayleigh, Proakis and Salehi chapter 13; Qarabaqi and Stojanovic,
   IEEE JOE 38(4), 2013, on the underwater channel's fading).

Two parameters are fitted, not derived: the fading's m = 3 and a receiver implementation loss of
5 dB put the curve where the PER curve of Newcastle's public starter simulation for these modems has
it (PER 1 below about -3 dB of band SNR, about 0 above 8 dB; tests/acoustic/test_per.py checks both
ends). Under the default channel, delivery is near 1 to about 1.3 km and near 0 by 2.5 km.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike, NDArray

from acoustic.airtime import CORRECTABLE_BYTES, FEC_BYTES
from acoustic.params import AcousticParams

# The channel decides thousands of receptions a mission: it reads success from a table per payload size,
# tabulated once on this SNR grid (dB) and interpolated linearly: within 1e-4 of the exact curve with
# fading (2e-5 at m = 3), within 5e-4 of the steeper unfaded one (tests/acoustic/test_channel_model.py).
SNR_STEP_DB = 0.05
SNR_GRID_DB = np.arange(-40.0, 60.0 + 1e-9, SNR_STEP_DB)
# The fading average: the power draw x = e^u on a grid of u from -14 to 4 (the trapezoid rule in u is
# smooth where the coded packet's success falls steeply in x). Its step is two of the SNR grid's, in
# natural log of power: on the grid, SNR times draw falls on one finer grid of SNRs, so a table is one
# sliding weighted sum over a few thousand points instead of a million (`_success_table`).
_LN_STEP = SNR_STEP_DB * math.log(10.0) / 10.0
_U_STRIDE = 2
_U = -14.0 + _U_STRIDE * _LN_STEP * np.arange(math.ceil(18.0 / (_U_STRIDE * _LN_STEP)) + 1)
_X = np.exp(_U)
PING_BYTES = 2  # a ping or command packet decodes like the shortest data packet


def bfsk_bit_error(ebn0: ArrayLike) -> NDArray[np.float64]:
    """Noncoherent BFSK's bit error probability at Eb/N0 (linear), 1/2 exp(-Eb/N0 / 2)."""
    return 0.5 * np.exp(-0.5 * np.asarray(ebn0, dtype=np.float64))


def load() -> None:
    """Import what the curve needs now (scipy.special, about 0.2 s): a front end calls this before its
    missions' clocks start, as every other module is imported before them."""
    import scipy.special  # noqa: F401


def coded_success(ebn0: ArrayLike, payload_bytes: ArrayLike) -> NDArray[np.float64]:
    """Probability that no more than 8 of the n + 16 coded bytes are wrong, in white noise."""
    # The binomial CDF (scipy.stats would add seconds to `vil modem`'s start), imported at first use:
    # scipy.special is 0.3 s of start-up that every run without [acoustic] would pay for nothing.
    from scipy.special import bdtr

    byte_error = -np.expm1(8.0 * np.log1p(-bfsk_bit_error(ebn0)))
    coded = np.asarray(payload_bytes, dtype=np.int64) + FEC_BYTES
    return np.asarray(bdtr(CORRECTABLE_BYTES, coded, byte_error), dtype=np.float64)


def success_probability(snr_db: ArrayLike, payload_bytes: ArrayLike, params: AcousticParams) -> NDArray[np.float64]:
    """P(packet decoded) for mean band SNRs (dB) and payload sizes (0: a ping, decoded as 2 bytes);
    broadcast together, shape of their broadcast."""
    snr = np.asarray(snr_db, dtype=np.float64)
    n = np.maximum(np.asarray(payload_bytes, dtype=np.int64), PING_BYTES)
    ebn0 = 10.0 ** ((snr + params.processing_gain_db - params.implementation_loss_db) / 10.0)
    if params.fading_m <= 0.0:
        return coded_success(ebn0, n)
    shape = np.broadcast_shapes(snr.shape, n.shape)
    ebn0_b, n_b = np.broadcast_to(ebn0, shape)[..., None], np.broadcast_to(n, shape)[..., None]
    faded = coded_success(ebn0_b * _X, n_b)
    return np.asarray(np.clip(faded @ _fading_weights(params.fading_m), 0.0, 1.0), dtype=np.float64)


@lru_cache(maxsize=8)
def _fading_weights(m: float) -> NDArray[np.float64]:
    """Quadrature weights of E[f(x)] for x ~ Gamma(m, 1/m) (unit mean power) on the grid `_X`."""
    log_pdf = m * math.log(m) - math.lgamma(m) + (m - 1.0) * np.log(_X) - m * _X  # Gamma(m, 1/m)
    w = np.exp(log_pdf) * _X * (_U[1] - _U[0])
    w[[0, -1]] *= 0.5
    return np.asarray(w / w.sum(), dtype=np.float64)


def packet_error_rate(snr_db: ArrayLike, payload_bytes: ArrayLike, params: AcousticParams) -> NDArray[np.float64]:
    """1 - `success_probability`."""
    return 1.0 - success_probability(snr_db, payload_bytes, params)


def expected_byte_errors(snr_db: float, payload_bytes: int, params: AcousticParams) -> float:
    """The mean number of wrong coded bytes of a packet at this SNR, unfaded (the emulator's `$Q`)."""
    ebn0 = 10.0 ** ((snr_db + params.processing_gain_db - params.implementation_loss_db) / 10.0)
    byte_error = -np.expm1(8.0 * np.log1p(-bfsk_bit_error(ebn0)))
    return float(byte_error * (max(payload_bytes, PING_BYTES) + FEC_BYTES))


@lru_cache(maxsize=130)
def _success_table(payload_bytes: int, params: AcousticParams) -> NDArray[np.float64]:
    """`success_probability` on SNR_GRID_DB: SNR i times draw j is fine SNR i + 2j, so the unfaded
    success is taken once on the fine grid and the fading average is a sliding weighted sum over it."""
    if params.fading_m <= 0.0:
        return success_probability(SNR_GRID_DB, payload_bytes, params)
    n = max(payload_bytes, PING_BYTES)
    first_db = SNR_GRID_DB[0] + params.processing_gain_db - params.implementation_loss_db
    span = _U_STRIDE * (_U.size - 1)  # fine steps from the weakest draw to the strongest
    fine = np.exp(first_db * math.log(10.0) / 10.0 + _U[0] + _LN_STEP * np.arange(SNR_GRID_DB.size + span))
    windows = np.lib.stride_tricks.sliding_window_view(coded_success(fine, n), span + 1)[:, ::_U_STRIDE]
    return np.asarray(np.clip(windows @ _fading_weights(params.fading_m), 0.0, 1.0), dtype=np.float64)


def success_lookup(snr_db: ArrayLike, payload_bytes: int, params: AcousticParams) -> NDArray[np.float64]:
    """`success_probability` of one payload size at many SNRs, from its table (clamped at the grid's ends)."""
    table = _success_table(max(int(payload_bytes), PING_BYTES), params)
    return np.interp(np.asarray(snr_db, dtype=np.float64), SNR_GRID_DB, table)
