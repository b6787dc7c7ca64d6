"""The acoustic channel's parameters: the scenario's `[acoustic]` table, with the sources of each default."""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class AcousticParams:
    """Defaults: the nanomodem v3 (Newcastle University, user guide v3.2) in the channel of
    Newcastle's public starter simulation for these modems and UnetStack's simple channel (NOTES.md,
    "Underwater acoustics")."""

    enabled: bool = False  # off: the paper's WiFi-only world (Table II unchanged)
    sound_speed_mps: float = 1500.0
    source_level_db: float = 168.0  # dB re 1 uPa at 1 m (nanomodem v3)
    frequency_khz: float = 28.0  # the centre of the modem's 24-32 kHz band, for absorption
    bandwidth_hz: float = 8000.0  # 24-32 kHz
    bit_rate_bps: float = 640.0  # the modem's raw rate
    noise_psd_db: float = 50.0  # ambient noise, dB re 1 uPa^2/Hz over the band (Newcastle's starter: 50)
    spreading_k: float = 2.0  # 10 k log10(d): 2 spherical (Newcastle's 20 log10 R), 1.5 "practical"
    # Each packet sees one faded SNR around the mean: Nakagami-m power (m = 1 Rayleigh; 0: no fading).
    # m = 3 and an implementation loss of 5 dB put the PER curve where Newcastle's starter simulation
    # has it (1 below about -3 dB, about 0 above 8 dB): acoustic/per.py.
    fading_m: float = 3.0
    implementation_loss_db: float = 5.0  # the real receiver against ideal noncoherent BFSK
    # A packet this strong at a receiver spoils another it overlaps there (about 3 km under the
    # defaults: UnetStack's interference range).
    interference_snr_db: float = -12.0
    guard_s: float = 0.2  # TDMA guard between slots (DESERT's TDMA examples: 0.1-0.2 s)
    max_packet_bytes: int = 64  # the longest packet a TDMA slot must hold (status reports fit)

    @property
    def processing_gain_db(self) -> float:
        """Bandwidth over bit rate: what the spread-spectrum receiver gains on the band's SNR."""
        return 10.0 * math.log10(self.bandwidth_hz / self.bit_rate_bps)
