"""The simulated aMussels' modems (mussel_sim/modems.py) on the emulator in lockstep: a depleted
aMussel's modem has no power, so it neither reports nor hears a call-up; a live one does both."""

from __future__ import annotations

import numpy as np

from acoustic.nanomodem.driver import ModemDriver, Outcome
from acoustic.nanomodem.emulator import ModemEmulator, RemoteUnit
from acoustic.nanomodem.lockstep import attach
from acoustic.nanomodem.ports import pipe
from acoustic.orders import CALL_UP
from acoustic.params import AcousticParams
from acoustic.status_packet import unpack
from acoustic.tdma import Owner, tdma_frame
from mavlink_dialect import Codec
from missiontime import VirtualClock
from mussel_sim.comms import FLEET_COMPONENT_ID, FLEET_SYSTEM_ID, CommsConfig, FleetRunner
from mussel_sim.fleet_state import FleetParams, state_from_arrays
from mussel_sim.geo import LocalFrame
from mussel_sim.modems import MusselModems
from mussel_sim.vocabulary import MusselState

GCS_UNIT, APAD = 0, 1


def test_a_depleted_amussel_is_silent_and_its_modem_hears_no_call_up() -> None:
    params = FleetParams(drift_half_width_m=0.0)
    # aMussel 5 has less than one step's drain left (eq. 1 at theta 30: 0.00052 a second): it depletes at once.
    state = state_from_arrays([3, 5], [10.0, 20.0], [0.0, 0.0], [0.9, 0.0005], params)
    fleet = FleetRunner(state, params, np.random.default_rng(0), LocalFrame(43.94, 15.44),
                        Codec(FLEET_SYSTEM_ID, FLEET_COMPONENT_ID), lambda _b: None,
                        config=CommsConfig(apad_ids=frozenset({APAD}), commanders=frozenset({255}),
                                           wifi_at_surface_only=True))
    clock = VirtualClock()
    host, unit = pipe()
    core = ModemEmulator(AcousticParams(), (RemoteUnit(3, (10.0, 0.0, 2.0)), RemoteUnit(5, (20.0, 0.0, 2.0))),
                         np.random.default_rng(1), address=GCS_UNIT)
    sea = attach(core, unit, clock)
    tdma = tdma_frame([3, 5], [APAD], 50.0, AcousticParams())
    modems = MusselModems(fleet, sea, tdma, GCS_UNIT, (0.0, 0.0))
    fleet.register(clock.scheduler, clock.now_us)
    modems.register(clock.scheduler, clock.now_us)
    driver = ModemDriver(host, clock)
    clock.sleep(2 * tdma.frame_s)
    assert fleet.state.state.tolist() == [MusselState.ACTIVE, MusselState.DEPLETED]
    assert core.unpowered == {5} and modems.counts["modems_powered_off"] == 1
    heard = {unpack(p.data).mussel_id for p in driver.received()}  # reports are unicasts: the id is inside
    assert heard == {3} and modems.counts["silent:at_surface_or_depleted"] >= 1  # only the live one reports
    # Each call-up in the aPad's slot, as the GCS sends it: no aMussel's report on the water meanwhile.
    apad_slot_s = next(k for k, slot in enumerate(tdma.slots) if slot.owner is Owner.APAD) * tdma.slot_s
    clock.sleep((apad_slot_s - clock.time()) % tdma.frame_s)
    assert driver.unicast_ack(5, CALL_UP).outcome is Outcome.TIMEOUT  # no power: no acknowledgement
    clock.sleep((apad_slot_s - clock.time()) % tdma.frame_s)
    assert driver.unicast_ack(3, CALL_UP).ok
    assert core.counts["remote_unpowered"] == 1 and modems.counts["heard:unicast_ack"] == 1
