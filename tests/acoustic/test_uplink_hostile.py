"""What the GCS's unit hears from the water is not trusted: a packet that is not a status report, or a
report with values no aMussel sends, is dropped and counted by reason and never reaches what the planner
knows; a good report does. Real bytes through the emulator, its pipe and the driver, on a virtual clock."""

from __future__ import annotations

import struct

import numpy as np

from acoustic.nanomodem.driver import ModemDriver
from acoustic.nanomodem.emulator import ModemEmulator, RemoteUnit
from acoustic.nanomodem.lockstep import attach
from acoustic.nanomodem.ports import pipe
from acoustic.params import AcousticParams
from acoustic.status_packet import LAYOUT, VERSION, StatusReport, pack
from acoustic.tdma import tdma_frame
from gcs.acoustic_net.uplink import AcousticUplink
from gcs.link.registry import VehicleRegistry
from missiontime.clocks import VirtualClock

GOOD = StatusReport(7, 0, 0, 0.5, 0.0, 43.94, 15.44, 3.0, 8.0, 20.0, 1013.0, 1.0)


def test_hostile_reports_are_counted_by_reason_and_a_good_one_is_known() -> None:
    clock = VirtualClock()
    core = ModemEmulator(AcousticParams(), (RemoteUnit(7, (10.0, 0.0, 3.0)),), np.random.default_rng(1))
    gcs_end, modem_end = pipe()
    emulator = attach(core, modem_end, clock)
    registry = VehicleRegistry()
    uplink = AcousticUplink(ModemDriver(gcs_end, clock), registry, clock, tdma_frame([7], [1], 50.0, AcousticParams()))
    uplink.register(clock.scheduler)
    good = pack(GOOD)
    hostile = [
        b"not a report",  # the wrong length
        bytes([VERSION + 1]) + good[1:],  # a version we do not read
        LAYOUT.pack(VERSION, 0, 7, 99, 100, 0, 439400000, 154400000, 300, 0, 0, 0, 0),  # no such state
        LAYOUT.pack(VERSION, 0, 0, 0, 100, 0, 439400000, 154400000, 300, 0, 0, 0, 0),  # aMussel 0
        LAYOUT.pack(VERSION, 0, 7, 0, 100, 0, 2_000_000_000, 154400000, 300, 0, 0, 0, 0),  # latitude 200 degrees
        b"$#\r\n" + b"\x00" * 27,  # the modem's own syntax in a 31-byte payload: its version byte is "$"
    ]
    for payload in [*hostile, good]:
        emulator.send(7, payload, 0)
        clock.sleep(3.0)  # each alone on the water
    assert dict(uplink.dropped) == {"report:length": 1, "report:version": 2, "report:state": 1,
                                    "report:mussel_id": 1, "report:lat_lon": 1}
    assert uplink.counts["reports_heard"] == 1 and list(registry.mussels) == [7]
    view = registry.mussels[7]
    assert abs(view.battery_frac - 0.5) < 1e-4 and view.simulated
    assert struct.calcsize(LAYOUT.format) == len(good)
