"""The fleet's MAVLink edge, over real encoded bytes: publish, commands, docking, ID collisions."""

from __future__ import annotations

import numpy as np
import pytest

from apad_sitl.vocabulary import Latch
from mavlink_dialect import Codec, mavlink, memory_pair
from missiontime import VirtualClock
from mussel_sim.battery import to_millivolts
from mussel_sim.comms import FLEET_COMPONENT_ID, FLEET_SYSTEM_ID, CommsConfig, FleetRunner
from mussel_sim.fleet_state import FleetParams, state_from_arrays
from mussel_sim.geo import LocalFrame
from mussel_sim.sensors import AnoxicPatch, pressure_hpa
from mussel_sim.vocabulary import MusselCommand, MusselState

FRAME = LocalFrame(43.9400, 15.4400)
APAD = 1
GCS = 255
STILL = FleetParams(drift_half_width_m=0.0)


class Wire:
    """What the fleet sent, decoded by an independent parser (as a GCS or aPad would)."""

    def __init__(self) -> None:
        self.frames: list[bytes] = []
        self.codec = Codec(GCS, 190)

    def send(self, data: bytes) -> None:
        self.frames.append(data)

    def messages(self, kind: str | None = None) -> list[mavlink.MAVLink_message]:
        msgs = [m for f in self.frames for m in self.codec.decode(f)]
        self.frames.clear()
        return [m for m in msgs if kind is None or m.get_type() == kind]


def make_runner(params: FleetParams = STILL, **kwargs: object) -> tuple[FleetRunner, Wire]:
    state = state_from_arrays([3, 5, 8], [0.0, 20.0, -30.0], [0.0, 10.0, 40.0], [0.9, 0.7, 0.5], params)
    wire = Wire()
    runner = FleetRunner(
        state, params, np.random.default_rng(0), FRAME, Codec(FLEET_SYSTEM_ID, FLEET_COMPONENT_ID), wire.send,
        **kwargs,  # type: ignore[arg-type]
    )
    return runner, wire


apad_codec = Codec(APAD, 1)
gcs_codec = Codec(GCS, 190)


def apad_position(x_m: float, y_m: float) -> bytes:
    lat, lon = FRAME.to_geodetic(x_m, y_m)
    lat_e7, lon_e7 = round(float(lat) * 1e7), round(float(lon) * 1e7)
    return apad_codec.encode(mavlink.MAVLink_global_position_int_message(0, lat_e7, lon_e7, 0, 0, 0, 0, 0, 0))


def slot_status(slot: int, mussel_id: int, latch: Latch) -> bytes:
    charging = int(latch == Latch.LATCHED)
    return apad_codec.encode(mavlink.MAVLink_dock_slot_status_message(0, slot, mussel_id, int(latch), charging))


def command(mussel_id: int, cmd: MusselCommand) -> bytes:
    return gcs_codec.encode(mavlink.MAVLink_amussel_command_message(APAD, mussel_id, int(cmd)))


def test_status_messages_carry_each_mussel() -> None:
    runner, wire = make_runner()
    runner.publish_status_task(1_500_000)
    msgs = wire.messages()
    assert [m.get_type() for m in msgs] == ["AMUSSEL_STATUS"] * 3
    s = runner.state
    lat, lon = FRAME.to_geodetic(s.x_m, s.y_m)
    for k, m in enumerate(msgs):
        assert (m.get_srcSystem(), m.get_srcComponent()) == (251, 25)
        assert m.mussel_id == s.ids[k]
        assert m.time_us == 1_500_000
        assert (m.lat, m.lon) == (round(lat[k] * 1e7), round(lon[k] * 1e7))
        assert m.battery == pytest.approx(s.battery_frac[k], rel=1e-7)  # float32 on the wire
        assert m.battery_voltage == round(float(to_millivolts(s.battery_frac[k])))
        assert (m.state, m.simulated) == (MusselState.ACTIVE, 1)
        assert m.depth == pytest.approx(STILL.seabed_depth_m)


def test_sensor_messages_sample_the_scenario_field() -> None:
    patch = AnoxicPatch(centre_x_m=20.0, centre_y_m=10.0, sigma_m=5.0)  # centred on aMussel 5
    runner, wire = make_runner(sensors=patch)
    runner.publish_sensors_task(0)
    msgs = wire.messages("AMUSSEL_SENSORS")
    assert [m.mussel_id for m in msgs] == [3, 5, 8]
    assert msgs[1].dissolved_oxygen == pytest.approx(8.0 - 7.0)
    assert msgs[1].pressure == pytest.approx(float(pressure_hpa(np.array([3.0]))[0]), rel=1e-6)
    assert msgs[0].dissolved_oxygen > msgs[1].dissolved_oxygen


def test_rates_in_lockstep() -> None:
    runner, wire = make_runner()
    clock = VirtualClock()
    runner.register(clock.scheduler)
    clock.sleep(10.0)
    msgs = wire.messages()
    status = [m for m in msgs if m.get_type() == "AMUSSEL_STATUS"]
    sensors = [m for m in msgs if m.get_type() == "AMUSSEL_SENSORS"]
    assert len(status) == 3 * 11  # 1 Hz at t = 0..10 s
    assert len(sensors) == 3 * 3  # 0.2 Hz at t = 0, 5, 10 s
    assert runner.state.step_index == 10  # the model stepped at 1 Hz, t = 1..10 s
    assert runner.state.time_us == 10_000_000
    assert runner.recorder.n_steps == 10
    # The step runs before the publish of the same instant: the last status shows t = 10 s battery.
    assert status[-1].battery == pytest.approx(runner.state.battery_frac[-1], rel=1e-7)


def test_repeated_instant_does_not_step_twice() -> None:
    runner, _ = make_runner()
    runner.step_task(1_000_000)
    runner.step_task(1_000_000)
    assert runner.state.step_index == 1


def test_surface_needs_an_apad_in_acoustic_range() -> None:
    runner, wire = make_runner()
    runner.feed(command(5, MusselCommand.SURFACE))
    runner.step_task(1_000_000)
    assert runner.state.state[1] == MusselState.ACTIVE
    warnings = wire.messages("STATUSTEXT")
    assert [w.text for w in warnings] == ["aMussel 5: SURFACE refused, no aPad in 100 m"]
    assert warnings[0].severity == mavlink.MAV_SEVERITY_WARNING

    runner.feed(apad_position(20.0 + 30.0, 10.0 + 40.0))  # 50 m from aMussel 5
    runner.feed(command(5, MusselCommand.SURFACE))
    runner.step_task(2_000_000)
    assert runner.state.state[1] == MusselState.SURFACING
    assert wire.messages("STATUSTEXT") == []


def test_dock_follow_and_release_from_dock_slot_status_bytes() -> None:
    runner, _ = make_runner()
    apad_side = Codec(GCS, 191)  # an independent decoder between the aPad's bytes and `handle`

    def deliver(data: bytes) -> None:
        for msg in apad_side.decode(data):
            runner.handle(msg)

    deliver(apad_position(22.0, 11.0))
    deliver(command(5, MusselCommand.SURFACE))
    for t in range(1, 22):
        runner.step_task(t * 1_000_000)
    assert runner.state.state[1] == MusselState.FLOATING

    deliver(slot_status(2, 5, Latch.CLOSING))
    runner.step_task(22_000_000)
    s = runner.state
    assert s.state[1] == MusselState.DOCKED
    assert (s.dock_apad[1], s.dock_slot[1]) == (APAD, 2)
    assert (s.x_m[1], s.y_m[1]) == pytest.approx((22.0, 11.0), abs=1e-2)  # on the aPad (degE7: ~1 cm)
    u_docked = s.battery_frac[1]

    # The aPad repeats its slot status every second and moves: no re-dock, the aMussel follows.
    deliver(slot_status(2, 5, Latch.LATCHED))
    deliver(apad_position(-5.0, 60.0))
    runner.step_task(23_000_000)
    s = runner.state
    assert s.state[1] == MusselState.DOCKED
    assert (s.x_m[1], s.y_m[1]) == pytest.approx((-5.0, 60.0), abs=1e-2)
    assert s.battery_frac[1] > u_docked
    assert runner.last_events is not None and runner.last_events.docked_ids.size == 0

    # Undock: the slot goes RELEASING (charging off), the aMussel sinks.
    deliver(slot_status(2, 5, Latch.RELEASING))
    runner.step_task(24_000_000)
    assert runner.state.state[1] == MusselState.SINKING
    deliver(slot_status(2, 0, Latch.OPEN))
    runner.step_task(25_000_000)
    assert runner.state.state[1] == MusselState.SINKING
    assert runner.last_events is not None and runner.last_events.released_ids.size == 0  # released once


def test_sink_command_over_the_wire() -> None:
    runner, _ = make_runner()
    runner.feed(apad_position(0.0, 0.0))
    runner.feed(command(3, MusselCommand.SURFACE))
    for t in range(1, 21):
        runner.step_task(t * 1_000_000)
    assert runner.state.state[0] == MusselState.FLOATING
    runner.feed(command(3, MusselCommand.SINK))
    runner.step_task(21_000_000)
    assert runner.state.state[0] == MusselState.SINKING


def test_slots_of_unknown_mussels_are_ignored() -> None:
    runner, _ = make_runner()
    runner.feed(slot_status(1, 999, Latch.LATCHED))  # a real aMussel on the aPad
    runner.step_task(1_000_000)
    assert (runner.state.state == MusselState.ACTIVE).all()


def real_status(mussel_id: int, simulated: int, system: int = 42) -> bytes:
    codec = Codec(system, 1)
    return codec.encode(
        mavlink.MAVLink_amussel_status_message(0, mussel_id, 439400000, 154400000, 2.0, 0.8, 4080, 0, simulated)
    )


def test_real_mussel_with_a_simulated_id_is_refused_loudly() -> None:
    runner, wire = make_runner()
    runner.feed(real_status(77, simulated=0))
    assert runner.real_mussel_ids == {77}
    runner.feed(real_status(5, simulated=0))  # refused and counted, never raised: no packet ends the fleet
    assert runner.real_mussel_ids == {77} and runner.dropped == {"id_collision:AMUSSEL_STATUS": 1}
    [warning] = wire.messages("STATUSTEXT")
    assert warning.text == "aMussel 5 also reported by system 42: refused"


def test_our_own_status_echoed_back_is_not_a_collision() -> None:
    runner, wire = make_runner()
    runner.publish_status_task(0)
    for frame in list(wire.frames):
        runner.feed(frame)
    assert runner.real_mussel_ids == set()


def test_ids_beyond_uint16_cannot_go_on_the_wire() -> None:
    state = state_from_arrays([70_000], [0.0], [0.0], [1.0], STILL)
    with pytest.raises(ValueError, match="65535"):
        FleetRunner(state, STILL, np.random.default_rng(0), FRAME, Codec(251, 25), lambda b: None)


def test_lockstep_over_an_in_memory_link() -> None:
    # The aPad end of a memory pair sends its position and a SURFACE command; the fleet end is
    # polled by the scheduler. After the surfacing time the aPad hears the aMussel FLOATING.
    fleet_end, apad_end = memory_pair("mussels")
    clock = VirtualClock()
    state = state_from_arrays([3, 5], [0.0, 20.0], [0.0, 10.0], [0.9, 0.7], STILL)
    runner = FleetRunner(
        state, STILL, np.random.default_rng(0), FRAME, Codec(251, 25), fleet_end.send,
        config=CommsConfig(sensors_rate_hz=0.1),
    )
    runner.register(clock.scheduler)
    clock.scheduler.add_poller(runner.poller(fleet_end))
    apad_end.send(apad_position(10.0, 10.0))
    apad_end.send(command(5, MusselCommand.SURFACE))
    clock.sleep(25.0)
    heard = Codec(APAD, 1)
    last = {}
    for data in apad_end.receive():
        for m in heard.decode(data):
            if m.get_type() == "AMUSSEL_STATUS":
                last[m.mussel_id] = m.state
    assert last == {3: MusselState.ACTIVE, 5: MusselState.FLOATING}


def test_with_a_keep_alive_an_unchanged_fleet_reports_each_window_and_a_change_at_once() -> None:
    runner, wire = make_runner(config=CommsConfig(status_keepalive_s=5.0))
    clock = VirtualClock()
    runner.register(clock.scheduler)
    clock.sleep(4.5)  # publishes at 0 .. 4: everyone at 0, then nothing changes
    statuses = wire.messages()
    heard = [(m.get_type(), getattr(m, "time_us", None)) for m in statuses]
    assert heard.count(("AMUSSEL_STATUS", 0)) == 3 and sum(1 for k, _ in heard if k == "AMUSSEL_STATUS") == 3
    # Every second its node's heartbeat (the link is alive between reports), a companion, not a vehicle.
    beats = [m for m in statuses if m.get_type() == "HEARTBEAT"]
    assert len(beats) == 5 and {(m.type, m.autopilot) for m in beats} == {
        (mavlink.MAV_TYPE_ONBOARD_CONTROLLER, mavlink.MAV_AUTOPILOT_INVALID)}
    runner.feed(apad_position(0.0, 0.0))  # an aPad in acoustic range
    runner.feed(command(5, MusselCommand.SURFACE))  # heard at 4.5 s: surfacing from the step at 5
    clock.sleep(2.0)  # publishes at 5 (a window: all) and 6 (none changed again)
    at = [(m.mussel_id, m.time_us, m.state) for m in wire.messages("AMUSSEL_STATUS")]
    assert at == [(3, 5_000_000, MusselState.ACTIVE), (5, 5_000_000, MusselState.SURFACING),
                  (8, 5_000_000, MusselState.ACTIVE)]
    runner.feed(command(3, MusselCommand.SURFACE))
    clock.sleep(1.0)  # the step at 7 changes aMussel 3: it alone reports, at once
    assert [(m.mussel_id, m.time_us) for m in wire.messages("AMUSSEL_STATUS")] == [(3, 7_000_000)]
    assert runner.reports.held == 3 * 4 + 3 + 2
