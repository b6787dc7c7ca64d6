"""Every message of our dialect, hostile field values, a valid CRC: into the GCS's and the SITL's receive
paths as a mission wires them (`hostile_packets.FuzzWorld`). No exception, no handler error, the
handlers reached (drops counted by reason, messages accepted), nothing impossible believed.

CI runs a few thousand inputs; by hand, e.g.

    VIL_FUZZ_EXAMPLES=200000 .venv/bin/pytest -q tests/robust/test_fuzz_hostile_fields.py

and bench/fuzz_receive.py runs a million and prints the figures.
"""

from __future__ import annotations

import os
from collections import Counter
from dataclasses import replace

import pytest
from hostile_packets import GCS_ORDERS, MESSAGE_CLASSES, STRANGERS, FuzzWorld, HostileFrames, senders

from apad_sitl.modem_serial import OWNER_SILENT_S
from gcs.mission.world import MISSION_TELEMETRY_HZ
from gcs.results.accounting import account
from gcs.scenario.reader import Scenario
from mavlink_dialect import mavlink

EXAMPLES = int(os.environ.get("VIL_FUZZ_EXAMPLES", "4000"))
ADVANCE_EVERY = 50  # inputs between two steps of mission time, so the models act on what they took


def test_the_generator_covers_every_message_of_the_dialect_and_packs_valid_frames() -> None:
    assert len(MESSAGE_CLASSES) == len(mavlink.mavlink_map) > 200
    frames = HostileFrames(3, senders((7, 1)))
    for _ in range(3000):
        frames.message()
    assert set(frames.drawn) == {cls.msgname for cls in MESSAGE_CLASSES}
    receiver = senders((250, 190))[0]
    decoded = [m for _ in range(500) for m in receiver.decode(frames.frame())]
    assert len(decoded) == 500 and receiver.stats.bad_data == 0  # every CRC valid: all reach a reader


@pytest.mark.parametrize("seed", [1, 2])
def test_hostile_fields_reach_both_receive_paths_and_nothing_impossible_is_believed(seed: int) -> None:
    fuzz = FuzzWorld(seed)
    w, gen = fuzz.world, fuzz.frames
    apad_received = fuzz.vehicle.codec.stats.received
    gcs_received = w.link._pollers[0].codec.stats.received
    try:
        for i in range(EXAMPLES):
            frame = gen.frame()
            fuzz.feed("gcs", frame)  # an exception here is the bug this test is for
            fuzz.feed("sitl", frame)
            if i % ADVANCE_EVERY == ADVANCE_EVERY - 1:
                fuzz.advance(0.3)
        assert fuzz.handler_errors() == {}
        assert fuzz.impossible() == []
        # Every frame was decoded on both sides (on top of the world's own traffic): the readers saw them.
        assert fuzz.vehicle.codec.stats.received - apad_received >= EXAMPLES
        assert w.link._pollers[0].codec.stats.received - gcs_received >= EXAMPLES
        drops = fuzz.drops()
        assert {"AMUSSEL_STATUS.state", "GLOBAL_POSITION_INT.lat_lon", "DOCK_SLOT_STATUS.slot"} <= set(drops["gcs"])
        assert {"spoofed_source:AMUSSEL_STATUS", "HEARTBEAT.system"} <= set(drops["gcs"])
        assert {"invalid:AMUSSEL_STATUS:lat", "invalid:COMMAND_LONG:param1", "invalid:PARAM_SET:param_id"} \
            <= set(drops["sitl"])
        assert len(drops["gcs"]) > 40 and len(drops["sitl"]) > 10
        # ... and some got through: the real aPad's link is still believed, strangers' aMussels are kept apart.
        assert w.link.vehicles.keys() == {1} and len(w.link.registry.mussels) >= 12
    finally:
        fuzz.close()


def test_hostile_modem_passthrough_reaches_the_apads_modem_and_the_gcss_port_without_harm() -> None:
    """pool12-acoustic: the aPad has a modem of its own (APAD_MODEM_SERIAL) and the GCS a port to it.
    Hostile passthrough frames, and every other message, into both paths: nothing raises, what does
    not fit is counted, the bytes that do reach the aPad's modem (its parser counts what is not a
    command), and a call-up through the aPad's modem still works afterwards."""
    modem_only = [cls for cls in MESSAGE_CLASSES if cls.msgname == "APAD_MODEM_SERIAL"]
    fuzz = FuzzWorld(7, scenario="missions/pool12-acoustic.toml", classes=modem_only, hostile_share=0.7)
    w = fuzz.world
    try:
        network = w.acoustic
        assert network is not None and network.emulator is not None
        for i in range(max(EXAMPLES // 4, 500)):
            frame = fuzz.frames.frame()
            fuzz.feed("gcs", frame)
            fuzz.feed("sitl", frame)
            if i % ADVANCE_EVERY == ADVANCE_EVERY - 1:
                fuzz.advance(0.3)
        assert fuzz.handler_errors() == {} and fuzz.impossible() == []
        sitl = fuzz.drops()["sitl"]
        assert sitl["invalid:APAD_MODEM_SERIAL:count"] > 0 and sitl["invalid:APAD_MODEM_SERIAL:flags"] > 0
        assert network.emulator.core.counts["stray_byte"] > 0  # what got through reached the modem's parser
        # A stranger that spoke to the modem first owns it until it has been silent OWNER_SILENT_S (MAVLink
        # signing is what keeps strangers out); then the GCS takes it. Replies spoofed in the aPad's name
        # moved the port's numbers and stream position: one command goes to catching up with them, and
        # the passthrough works again.
        fuzz.advance(OWNER_SILENT_S + 1.0)
        driver = network.call_ups.apad_units[1]
        driver.status()
        assert driver.status().ok and driver.status().ok  # (a ping now, out of the aPad's slot, could collide)
    finally:
        fuzz.close()


def test_no_stranger_disturbs_a_mission_every_mussel_is_accounted_for() -> None:
    """The mission loop runs while strangers spray both sides: it runs to its end, and each aMussel
    is on the seabed or in a slot. (Orders a stranger GCS may give the aPad are left out: any GCS may
    command a MAVLink vehicle; the SITL's validation of them is what the test above and
    tests/unit/test_sitl_hostile.py check.)"""
    fuzz = FuzzWorld(4, senders_ids=STRANGERS)
    quiet = [cls for cls in MESSAGE_CLASSES if cls.msgname not in GCS_ORDERS]
    to_apad = HostileFrames(5, senders(*STRANGERS), classes=quiet)
    w = fuzz.world
    per_tick = max(1, EXAMPLES // 2000)

    def spray(now_us: int) -> None:
        for _ in range(per_tick):
            fuzz.to_gcs.send(fuzz.frames.frame())
            fuzz.to_apad.send(to_apad.frame())

    try:
        w.api.wait_apad(timeout_s=10.0)
        w.api.set_telemetry_rates(MISSION_TELEMETRY_HZ)
        w.clock.scheduler.every(0.1, spray, "spray", w.clock.now_us)
        w.scenario = _short(w.scenario, 300.0)
        loop = w.mission_loop()
        assert str(loop.run()) == "mission time"
        assert fuzz.handler_errors() == {} and fuzz.impossible() == []
        homes = {m: (h.lat, h.lon) for m, h in w.homes.items()}
        where = Counter(a.where for a in account(w.fleet.state, w.frame, homes, w.link.vehicles))
        assert set(where) <= {"seabed", "slot"} and where.total() == 12
        assert w.link.dropped.total() > 1000 and w.fleet.dropped.total() > 0
    finally:
        fuzz.close()


def _short(scenario: Scenario, duration_s: float) -> Scenario:
    return replace(scenario, mission=replace(scenario.mission, duration_s=duration_s))


def test_the_fleet_alone_takes_hostile_frames_without_raising_or_believing_them() -> None:
    """The fleet's own receive path (`FleetRunner.feed`, as its transport poller calls it), open to any
    aPad: nothing raises, positions and slots out of range are counted, never taken."""
    fuzz = FuzzWorld(6)
    fleet = fuzz.world.fleet
    fleet.config = replace(fleet.config, apad_ids=None, commanders=None)
    try:
        for _ in range(EXAMPLES):
            fleet.feed(fuzz.frames.frame())
        fleet.step_task(fleet.state.time_us + 1_000_000)
        assert not [k for k in fleet.dropped if "handler_error" in k]
        assert {"invalid:DOCK_SLOT_STATUS:slot", "invalid:GLOBAL_POSITION_INT:lat_lon",
                "invalid:AMUSSEL_COMMAND:command"} <= set(fleet.dropped)
        assert all(abs(lat) <= 90 and abs(lon) <= 180 for lat, lon in fleet.apads.deg.values())
        assert all(1 <= slot <= 4 for _, slot in fleet.orders.docked_at.values())
    finally:
        fuzz.close()
