"""MAVLink 2 signing: the signing aPad refuses forged, unsigned, wrongly signed and replayed commands."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from robust_helpers import SYSID, latlon_e7, sitl_pair

from apad_sitl.vocabulary import Latch
from gcs.link.faultproxy import LinkFaults
from gcs.mission.headless import run_mission
from gcs.mission.world import LinkOptions
from gcs.scenario.reader import load_scenario
from mavlink_dialect import MAV_CMD_APAD_DOCK, Codec, hot, mavlink, signing
from mavlink_dialect.signing import SigningKeyError, key_from_passphrase, load_key
from mussel_sim.comms import FLEET_COMPONENT_ID, FLEET_SYSTEM_ID

pytestmark = pytest.mark.sitl

KEY = key_from_passphrase("biograd 2020")
EPOCH_US = 1_591_920_000_000_000


def dock_msg(slot: int, mussel_id: int) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_command_long_message(SYSID, 1, MAV_CMD_APAD_DOCK, 0, slot, mussel_id, 0, 0, 0, 0, 0)


def signed_gcs_codec(key: bytes = KEY, ticks: int = 0) -> Codec:
    codec = Codec(250, 190)
    codec.enable_signing(key, link_id=1, ticks=lambda: signing.timestamp_ticks(EPOCH_US, ticks))
    return codec


def signed_fleet_codec(now_us: int) -> Codec:
    codec = Codec(FLEET_SYSTEM_ID, FLEET_COMPONENT_ID)
    codec.enable_signing(KEY, link_id=1, ticks=lambda: signing.timestamp_ticks(EPOCH_US, now_us))
    return codec


def mussel_status(codec: Codec, mussel_id: int, x_m: float, y_m: float) -> bytes:
    lat, lon = latlon_e7(x_m, y_m)
    return codec.encode(mavlink.MAVLink_amussel_status_message(0, mussel_id, lat, lon, 0.0, 0.8, 4080, 0, 1))


def fleet_batch(codec: Codec, ids: list[int]) -> list[bytes]:
    """AMUSSEL_STATUS of several aMussels as the fleet sends them: the batch path, packed in datagrams."""
    lat, lon = latlon_e7(0.5, 0.0)
    n = len(ids)
    frames = hot.encode_batch(codec, hot.AMUSSEL_STATUS, {
        "time_us": 0, "mussel_id": np.array(ids), "lat": np.full(n, lat), "lon": np.full(n, lon), "depth": 0.0,
        "battery": 0.8, "battery_voltage": 4080, "state": 0, "simulated": 1})
    return hot.pack_datagrams(frames)


def test_unsigned_amussel_status_is_refused_while_signing_is_on_and_signed_is_taken() -> None:
    clock, vehicle, gcs = sitl_pair(signing_key=KEY, log_epoch_us=EPOCH_US)
    gcs.mussel(24, 0.5, 0.0)  # one unsigned frame
    for datagram in fleet_batch(Codec(FLEET_SYSTEM_ID, FLEET_COMPONENT_ID), [25, 26, 27]):  # the batch path
        gcs.send_raw(datagram)
    clock.sleep(0.5)
    assert not {24, 25, 26, 27} & set(vehicle.mussels)
    assert vehicle.codec.signing_refusals == {"unsigned": 4}
    for datagram in fleet_batch(signed_fleet_codec(clock.now_us), [25, 26, 27]):
        gcs.send_raw(datagram)
    clock.sleep(0.5)
    assert {25, 26, 27} <= set(vehicle.mussels)
    assert vehicle.codec.signing_refusals == {"unsigned": 4}
    vehicle.close()


def test_forged_unsigned_dock_is_refused_and_a_signed_one_docks() -> None:
    clock, vehicle, gcs = sitl_pair(signing_key=KEY, log_epoch_us=EPOCH_US)
    gcs.send_raw(mussel_status(signed_fleet_codec(clock.now_us), 24, 0.5, 0.0))  # the fleet signs too
    assert 24 in vehicle.mussels

    gcs.command_long(MAV_CMD_APAD_DOCK, 1, 24)  # the stray, unsigned dock
    clock.sleep(2.0)
    assert gcs.acks(MAV_CMD_APAD_DOCK) == []
    assert vehicle.primitive.slot_state(1).latch == Latch.OPEN
    assert vehicle.codec.signing_rejects == 1

    wrong = signed_gcs_codec(key_from_passphrase("not the key"))
    gcs.send_raw(wrong.encode(dock_msg(1, 24)))
    clock.sleep(2.0)
    assert gcs.acks(MAV_CMD_APAD_DOCK) == []
    assert vehicle.codec.signing_rejects == 2

    gcs.codec = signed_gcs_codec()
    frame = gcs.command_long(MAV_CMD_APAD_DOCK, 1, 24)
    clock.sleep(1.0)
    [ack] = gcs.acks(MAV_CMD_APAD_DOCK)  # the aPad signs its answers; our codec checked the signature
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED
    assert vehicle.primitive.slot_state(1).latch == Latch.CLOSING

    # Someone recorded that frame and plays it back later: a replay, refused before it is parsed.
    clock.sleep(30.0)
    rejects = vehicle.codec.signing_rejects
    gcs.send_raw(frame)
    clock.sleep(1.0)
    assert vehicle.codec.signing_rejects == rejects + 1
    assert len(gcs.acks(MAV_CMD_APAD_DOCK)) == 1
    vehicle.close()


def test_signing_timestamps_follow_the_virtual_clock_deterministically() -> None:
    frames = []
    for _ in range(2):
        codec = signed_gcs_codec(ticks=5_000_000)
        frames.append(codec.encode(mavlink.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3)))
    assert frames[0] == frames[1]
    stamp = int.from_bytes(frames[0][-12:-6], "little")
    assert stamp == signing.timestamp_ticks(EPOCH_US, 5_000_000)


def test_key_from_file_or_environment(tmp_path: Path) -> None:
    f = tmp_path / "key"
    f.write_text("biograd 2020\n")
    assert load_key(f) == KEY
    assert load_key(None, {"VIL_SIGNING_KEY": "biograd 2020"}) == KEY
    assert load_key(None, {}) is None
    (tmp_path / "empty").write_text("\n")
    with pytest.raises(SigningKeyError, match="empty"):
        load_key(tmp_path / "empty")
    with pytest.raises(SigningKeyError, match="cannot read"):
        load_key(tmp_path / "missing")


def test_a_signed_mission_over_the_proxy_completes() -> None:
    s = load_scenario("pool12").with_overrides(strategy="greedy", duration_s=600.0)
    r = run_mission(s, options=LinkOptions(faults=LinkFaults(seed=3), signing_key=KEY))
    assert r.end_reason == "mission time" and r.cycles >= 1
    assert r.messages["gcs_bad_data"] == 0 and r.messages["apad_bad_data"] == 0
    assert all(w["where"] != "lost" for w in r.whereabouts)


def test_a_forged_frame_stamped_in_the_future_does_not_block_the_genuine_stream() -> None:
    clock, vehicle, gcs = sitl_pair(signing_key=KEY, log_epoch_us=EPOCH_US)
    gcs.send_raw(mussel_status(signed_fleet_codec(clock.now_us), 24, 0.5, 0.0))
    forger = Codec(250, 190)
    forger.enable_signing(key_from_passphrase("guess"), link_id=1, ticks=lambda: 2**47)  # far future, same stream
    gcs.send_raw(forger.encode(dock_msg(2, 24)))
    gcs.codec = signed_gcs_codec(ticks=clock.now_us)
    gcs.command_long(MAV_CMD_APAD_DOCK, 1, 24)
    clock.sleep(1.0)
    assert [a.result for a in gcs.acks(MAV_CMD_APAD_DOCK)] == [mavlink.MAV_RESULT_ACCEPTED]
    assert vehicle.primitive.slot_state(1).latch == Latch.CLOSING
    vehicle.close()
