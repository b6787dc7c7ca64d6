"""The scenario's `[acoustic]` table: the acoustic channel's parameters (`acoustic.params`), read
through the one reader's `Fields` (so the schema describes it too). Absent or `enabled = false`:
the paper's WiFi-only world, Table II unchanged."""

from __future__ import annotations

from acoustic.airtime import MAX_PAYLOAD, MIN_PAYLOAD
from acoustic.params import AcousticParams
from gcs.scenario.fields import Fields

_D = AcousticParams()


def read_acoustic(a: Fields) -> AcousticParams:
    params = AcousticParams(
        enabled=a.flag("enabled", _D.enabled, about="submerged aMussels heard only through the acoustic "
                       "channel (docs/acoustic.md); false: the paper's WiFi-only world"),
        sound_speed_mps=a.number("sound_speed_mps", _D.sound_speed_mps, lo=1300.0, hi=1700.0),
        source_level_db=a.number("source_level_db", _D.source_level_db, lo=100.0, hi=220.0,
                                 about="dB re 1 uPa at 1 m (nanomodem v3: 168)"),
        frequency_khz=a.number("frequency_khz", _D.frequency_khz, lo=1.0, hi=200.0,
                               about="the band's centre, for Thorp's absorption (nanomodem: 24-32 kHz)"),
        bandwidth_hz=a.number("bandwidth_hz", _D.bandwidth_hz, lo=100.0, hi=200_000.0),
        bit_rate_bps=a.number("bit_rate_bps", _D.bit_rate_bps, lo=10.0, hi=100_000.0),
        noise_psd_db=a.number("noise_psd_db", _D.noise_psd_db, lo=0.0, hi=150.0,
                              about="ambient noise spectral level over the band, dB re 1 uPa^2/Hz"),
        spreading_k=a.number("spreading_k", _D.spreading_k, lo=1.0, hi=2.0,
                             about="spreading loss 10 k log10(range): 2 spherical, 1.5 practical, 1 cylindrical"),
        fading_m=a.number("fading_m", _D.fading_m, lo=0.0, hi=100.0,
                          about="Nakagami-m fading of each packet's SNR (1: Rayleigh; 0: none)"),
        implementation_loss_db=a.number("implementation_loss_db", _D.implementation_loss_db, lo=0.0, hi=40.0,
                                        about="the receiver against ideal noncoherent BFSK"),
        interference_snr_db=a.number("interference_snr_db", _D.interference_snr_db, lo=-60.0, hi=60.0,
                                     about="a packet this strong at a receiver spoils another it overlaps there"),
        guard_s=a.number("guard_s", _D.guard_s, lo=0.0, hi=60.0, about="TDMA guard between slots"),
        max_packet_bytes=a.integer("max_packet_bytes", _D.max_packet_bytes, lo=MIN_PAYLOAD, hi=MAX_PAYLOAD,
                                   about="the longest packet a TDMA slot holds"),
    )
    a.done()
    return params
