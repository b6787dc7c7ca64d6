"""A submerged aMussel's status report, sent in its TDMA slot: 31 bytes (a nanomodem payload is 2-64).

Layout, little-endian (`struct` format `LAYOUT`), each field's unit and quantum:

    version u8 (1) | seq u8 | mussel_id u16 | state u8 | battery u16 (1/65535 of full)
    fix_time u32 (s of mission time of the last position fix) | lat i32, lon i32 (1e-7 deg)
    depth u16 (cm) | dissolved oxygen u16 (0.001 mg/L) | temperature i16 (0.01 degC)
    pressure u32 (0.1 hPa) | turbidity u16 (0.1 NTU)

Physical values outside a field's range are clipped to it (a sensor's wild reading still fits);
ids, state and seq out of range are refused. `unpack` refuses a payload of the wrong length or
version with a `PacketError` naming the reason (the receiver counts it).
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass

VERSION = 1
LAYOUT = struct.Struct("<BBHBHIiiHHhIH")
SIZE = LAYOUT.size

# field -> (scale: units per quantum, lo, hi) of the stored integer
_U16, _I16, _U32, _I32 = (0, 0xFFFF), (-0x8000, 0x7FFF), (0, 0xFFFFFFFF), (-0x80000000, 0x7FFFFFFF)
SCALES = {
    "battery_frac": (65535.0, _U16), "fix_time_s": (1.0, _U32), "lat_deg": (1e7, _I32), "lon_deg": (1e7, _I32),
    "depth_m": (100.0, _U16), "dissolved_oxygen_mg_l": (1000.0, _U16), "temperature_degc": (100.0, _I16),
    "pressure_hpa": (10.0, _U32), "turbidity_ntu": (10.0, _U16),
}


class PacketError(ValueError):
    def __init__(self, reason: str, detail: str) -> None:
        super().__init__(f"{reason}: {detail}")
        self.reason = reason


@dataclass(frozen=True)
class StatusReport:
    mussel_id: int
    seq: int  # 0..255, wraps: a repeated or missing report shows
    state: int  # mussel_sim.vocabulary.MusselState's value
    battery_frac: float
    fix_time_s: float
    lat_deg: float
    lon_deg: float
    depth_m: float
    dissolved_oxygen_mg_l: float
    temperature_degc: float
    pressure_hpa: float
    turbidity_ntu: float


def _quantise(name: str, value: float) -> int:
    scale, (lo, hi) = SCALES[name]
    if not math.isfinite(value):
        raise ValueError(f"{name}: {value} is not a finite number")
    return min(max(round(value * scale), lo), hi)


def pack(report: StatusReport) -> bytes:
    """The report's 31 bytes."""
    for name, value, hi in (("mussel_id", report.mussel_id, 0xFFFF), ("state", report.state, 0xFF),
                            ("seq", report.seq, 0xFF)):
        if not 0 <= value <= hi:
            raise ValueError(f"{name}: {value} is outside [0, {hi}]")
    q = {name: _quantise(name, getattr(report, name)) for name in SCALES}
    return LAYOUT.pack(VERSION, report.seq, report.mussel_id, report.state, q["battery_frac"], q["fix_time_s"],
                       q["lat_deg"], q["lon_deg"], q["depth_m"], q["dissolved_oxygen_mg_l"],
                       q["temperature_degc"], q["pressure_hpa"], q["turbidity_ntu"])


def unpack(payload: bytes) -> StatusReport:
    """The report in a payload; `PacketError` ("length" or "version") if it is not one."""
    if len(payload) != SIZE:
        raise PacketError("length", f"a status report is {SIZE} bytes, got {len(payload)}")
    (version, seq, mussel_id, state, battery, fix_time, lat, lon, depth, oxygen, temperature, pressure,
     turbidity) = LAYOUT.unpack(payload)
    if version != VERSION:
        raise PacketError("version", f"expected version {VERSION}, got {version}")
    return StatusReport(
        mussel_id, seq, state, battery / SCALES["battery_frac"][0], float(fix_time), lat / 1e7, lon / 1e7,
        depth / SCALES["depth_m"][0], oxygen / SCALES["dissolved_oxygen_mg_l"][0],
        temperature / SCALES["temperature_degc"][0], pressure / SCALES["pressure_hpa"][0],
        turbidity / SCALES["turbidity_ntu"][0])
