"""Sound from one node to another: delay, transmission loss, noise and SNR (vectorised over ranges).

Transmission loss is spreading plus absorption, TL = 10 k log10(d) + d a(f) (Stojanovic, "On the
relationship between capacity and distance in an underwater acoustic communication channel",
ACM WUWNet 2006 / MC2R 2007, eq. 1-3), with Thorp's absorption a(f) in dB/km for f in kHz, as the
same paper and ns-3's `UanPropModelThorp` give it:

    a(f) = 0.11 f^2 / (1 + f^2) + 44 f^2 / (4100 + f^2) + 2.75e-4 f^2 + 0.003

(W. H. Thorp, "Analytic description of the low-frequency attenuation coefficient", JASA 42, 1967;
the formula holds above a few hundred Hz, well below the modem's 24-32 kHz). Noise is a flat
spectral level over the band, as in Newcastle's starter simulation for these modems
(NL = 50 + 10 log10 8000 dB re 1 uPa).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from acoustic.params import AcousticParams

MIN_RANGE_M = 1.0  # the source level's reference distance: no gain closer than 1 m


def thorp_db_per_km(frequency_khz: ArrayLike) -> NDArray[np.float64]:
    """Thorp's absorption coefficient, dB/km, for frequencies in kHz (about 7.4 dB/km at 28 kHz)."""
    f2 = np.square(np.asarray(frequency_khz, dtype=np.float64))
    return 0.11 * f2 / (1.0 + f2) + 44.0 * f2 / (4100.0 + f2) + 2.75e-4 * f2 + 0.003


def transmission_loss_db(range_m: ArrayLike, params: AcousticParams) -> NDArray[np.float64]:
    """Spreading (10 k log10 d) plus absorption at the band's centre; ranges under 1 m count as 1 m."""
    d = np.maximum(np.asarray(range_m, dtype=np.float64), MIN_RANGE_M)
    return 10.0 * params.spreading_k * np.log10(d) + d / 1000.0 * thorp_db_per_km(params.frequency_khz)


def noise_level_db(params: AcousticParams) -> float:
    """Noise over the band, dB re 1 uPa: the spectral level plus 10 log10(bandwidth)."""
    return params.noise_psd_db + 10.0 * math.log10(params.bandwidth_hz)


def snr_db(range_m: ArrayLike, params: AcousticParams) -> NDArray[np.float64]:
    """The band's mean SNR at each range: source level less transmission loss and noise."""
    return params.source_level_db - transmission_loss_db(range_m, params) - noise_level_db(params)


def delay_s(range_m: ArrayLike, params: AcousticParams) -> NDArray[np.float64]:
    """Propagation delay: range over the speed of sound."""
    return np.asarray(range_m, dtype=np.float64) / params.sound_speed_mps


def ranges_m(source_m: NDArray[np.float64], points_m: NDArray[np.float64]) -> NDArray[np.float64]:
    """Straight-line distances from one (3,) position to (n, 3) positions (x east, y north, z down, m)."""
    return np.asarray(np.linalg.norm(points_m - source_m, axis=-1), dtype=np.float64)
