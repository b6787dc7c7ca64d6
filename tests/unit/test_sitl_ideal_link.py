"""The SITL aPad's ideal-link mode (`SitlVehicle(..., ideal_link=True)`, issue 37) against lockstep's.

Two real SITL aPads run the same GCS script over real MAVLink bytes (`memory_pair`) on a virtual
clock, one in lockstep's mode and one on the ideal link: telemetry paced as the mission loop paces
it (fast while moving, slow while holding), a Go To, an hour resting away from home (the battery
draining), a requested message, a parameter set over the link and one set by the world, a Go To
home, a charge at the home charger and an hour held full there. The GCS end decodes what each sent.

The ideal link sends exactly what lockstep sends with each stream's repeats left out (every stamp
the same; its Go To cruising in closed form, `apad_sitl.cruise`, moves the hull as stepping does to
float noise, far below what is reported; a battery report is a repeat within its 10-mV step,
`by_exception.BATTERY_STEP_MV`): the GCS knows at every instant what lockstep's GCS knows, its battery
to that step, and is told nothing twice; and while the hull rests almost nothing of the aPad runs.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import astuple, dataclass, field, replace
from itertools import pairwise
from typing import Any

import pytest
from testkit import command_bytes, go_to_bytes

from apad_sitl.by_exception import BATTERY_STEP_MV, report_key, stream_of
from apad_sitl.endpoint import SitlVehicle
from apad_sitl.params import ApadParams
from apad_sitl.streams import DEFAULT_RATES_HZ
from apad_sitl.vehicle import BATTERY_FULL_V, VehicleState
from mavlink_dialect import Codec, mavlink, memory_pair
from missiontime import US_PER_S, Scheduler, VirtualClock
from mussel_sim.geo import LocalFrame

HOME = (43.94, 15.44)
FRAME = LocalFrame(*HOME)
END_S = 9_000
GPI = mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT
PRIM = mavlink.MAVLINK_MSG_ID_PRIMITIVE_STATUS
SYS = mavlink.MAVLINK_MSG_ID_SYS_STATUS
BATT = mavlink.MAVLINK_MSG_ID_BATTERY_STATUS
DOCK = mavlink.MAVLINK_MSG_ID_DOCK_SLOT_STATUS
ATT = mavlink.MAVLINK_MSG_ID_ATTITUDE
# As gcs/loop/telemetry_pace.py asks: moving, then holding (and ATTITUDE, which a rest never changes).
MOVING_HZ = {GPI: 2.0, PRIM: 1.0, DOCK: 0.2, SYS: 0.2, BATT: 0.2, ATT: 1.0}
HOLDING_HZ = {GPI: 0.2, PRIM: 0.2}
BATTERY_PERIOD_S = 5.0
REST = (300, 1_800)  # resting away from home, nothing asked: the window the tasks are counted in
AT_HOME_FULL = (6_000, END_S)  # held full at the home charger






def _rates(gcs: Codec, rates_hz: dict[int, float]) -> list[bytes]:
    return [command_bytes(gcs, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, round(US_PER_S / hz))
            for msg_id, hz in rates_hz.items()]


@dataclass
class Run:
    """What one aPad sent (with the instant the GCS read it), what its tasks did, and how it ended."""

    heard: list[tuple[int, Any]] = field(default_factory=list)
    fired: list[tuple[int, str]] = field(default_factory=list)  # (instant, task) of every task of the aPad
    battery_stale: list[tuple[int, int, int]] = field(default_factory=list)  # (t, heard mV, latest true mV)
    end: tuple[Any, ...] = ()
    failsafe_holds: int = 0


def _run(ideal: bool) -> Run:
    apad_end, gcs_end = memory_pair()
    clock = VirtualClock(Scheduler())
    params = ApadParams(fs_gcs_enable=1, home_charge_w=1_000.0)
    vehicle = SitlVehicle(apad_end, params, *HOME, ideal_link=ideal)
    vehicle.state = VehicleState(x_m=0.0, y_m=0.0, battery_v=15.0)
    gcs = Codec(250, 190)
    run = Run()
    true_mv: list[tuple[int, int]] = []  # (t, the mV SYS_STATUS would report then)
    heard_mv: int | None = None

    def script(now_us: int) -> None:  # the GCS, before the aPad in each instant's order
        t = now_us // US_PER_S
        out: list[bytes] = []
        if t == 1:
            out += _rates(gcs, MOVING_HZ)
        elif t == 5:
            out.append(go_to_bytes(gcs, FRAME, 15.0, 0.0))
        elif t == 90:
            out += _rates(gcs, HOLDING_HZ)
        elif t == 1_800:
            out.append(command_bytes(gcs, mavlink.MAV_CMD_REQUEST_MESSAGE, SYS))
        elif t == 2_400:  # a faster hotel drain, set over the link
            out.append(gcs.encode(mavlink.MAVLink_param_set_message(
                1, 1, b"BATT_DRAIN_IDLE", 2.0, mavlink.MAV_PARAM_TYPE_REAL32)))
        elif t == 3_000:  # and back, set by the world (no message: `ApadState.changed_while_parked`)
            vehicle.params = replace(vehicle.params, batt_drain_idle_vph=0.5)
        elif t == 4_000:
            out += _rates(gcs, {GPI: 2.0, PRIM: 1.0})
            out.append(go_to_bytes(gcs, FRAME, 0.0, 0.0))
        elif t == 4_100:
            out += _rates(gcs, HOLDING_HZ)
        for data in out:
            gcs_end.send(data)

    def reader(now_us: int) -> None:  # the GCS's ear, after the aPad in each instant's order
        nonlocal heard_mv
        for data in gcs_end.receive():
            for msg in gcs.decode(data):
                run.heard.append((now_us, msg))
                if msg.get_msgId() == SYS:
                    heard_mv = msg.voltage_battery
        true_mv.append((now_us, round(vehicle.state.battery_v * 1000.0)))
        if heard_mv is not None and now_us >= 10 * US_PER_S:  # within a step of what a report a period ago said
            recent = [mv for t, mv in true_mv if t >= now_us - BATTERY_PERIOD_S * US_PER_S]
            if not any(abs(heard_mv - mv) < BATTERY_STEP_MV for mv in recent):
                run.battery_stale.append((now_us, heard_mv, true_mv[-1][1]))
            del true_mv[:-60]

    clock.scheduler.every(1.0, script, "gcs")
    vehicle.attach(clock.scheduler)
    for task in clock.scheduler.tasks:
        if task.name.startswith("apad1."):
            task.callback = _counted(task.callback, task.name, run.fired)
    clock.scheduler.every(0.1, reader, "gcs-ear")
    clock.sleep(END_S)
    run.end = (vehicle.state, vehicle.energy_counters, vehicle.params, vehicle.mode, dict(vehicle.dropped))
    run.failsafe_holds = vehicle.modes.failsafe_holds
    vehicle.close()
    return run


def _counted(callback: Any, name: str, fired: list[tuple[int, str]]) -> Any:
    def counted(now_us: int) -> None:
        fired.append((now_us, name))
        callback(now_us)
    return counted


def _by_exception(heard: list[tuple[int, Any]], noise: bool = False) -> list[tuple[int, str, dict[str, Any]]]:
    """What was heard with each stream's repeats (time stamps aside) left out. `noise`: float fields rounded to
    1e-9 first (what the closed forms of a busy hull change: a yaw rate of 1e-13 rad/s, 1e-13 m to go)."""
    last: dict[tuple[int, int], tuple[Any, ...]] = {}
    out = []
    for t, msg in heard:
        said = msg.to_dict()
        if noise:
            said = {k: round(v, 9) if isinstance(v, float) else v for k, v in said.items()}
        if msg.get_msgId() in DEFAULT_RATES_HZ:
            stream = stream_of(msg)
            key = report_key(msg)
            if noise:
                key = tuple(round(v, 9) if isinstance(v, float) else v for v in key)
            if last.get(stream) == key:
                continue
            last[stream] = key
        out.append((t, msg.get_type(), said))
    return out


@pytest.fixture(scope="module")
def runs() -> tuple[Run, Run]:
    return _run(False), _run(True)


def _in(run: Run, window: tuple[int, int], type_: str | None = None) -> list[tuple[int, Any]]:
    lo, hi = window[0] * US_PER_S, window[1] * US_PER_S
    return [(t, m) for t, m in run.heard if lo <= t < hi and (type_ is None or m.get_type() == type_)]


def test_the_ideal_link_sends_what_lockstep_sends_but_its_repeats_every_stamp_the_same(runs: tuple[Run, Run]) -> None:
    lockstep, ideal = runs
    # The same aPad: hull and energy (to float noise: the Go Tos' cruises in closed form, apad_sitl.cruise),
    # parameters, mode
    assert ideal.end[2:] == lockstep.end[2:]
    for i in (0, 1):
        assert astuple(ideal.end[i]) == pytest.approx(astuple(lockstep.end[i]), rel=0.0, abs=1e-9)
    assert _by_exception(ideal.heard, noise=True) == _by_exception(lockstep.heard, noise=True)
    # and no more: but for the SYS_STATUS requested, a repeat sent because it was asked for (and a change
    # at the level of float noise: ATTITUDE's yaw rate of 1e-13 rad/s, once, where lockstep's was 0)
    assert len(_by_exception(lockstep.heard)) + 1 <= len(ideal.heard) <= len(_by_exception(lockstep.heard)) + 2
    assert len(ideal.heard) < len(lockstep.heard) / 5
    state, energy, params, _, dropped = ideal.end
    # As scripted: charged at home from the start (at 15 V) till the Go To, then once back home and held full.
    assert state.battery_v == BATTERY_FULL_V and energy.home_charges == 2 and energy.home_wh > 50.0
    assert params.batt_drain_idle_vph == 0.5 and dropped == {}


def test_no_periodic_heartbeat_one_at_attach_and_one_per_mode_change(runs: tuple[Run, Run]) -> None:
    lockstep, ideal = runs
    beats = [(t, m.custom_mode) for t, m in ideal.heard if m.get_type() == "HEARTBEAT"]
    assert beats[0][0] == 0 and len(beats) == 2  # at attach (HOLD), then GUIDED by the first Go To
    assert beats[1][1] != beats[0][1]
    assert sum(1 for _, m in lockstep.heard if m.get_type() == "HEARTBEAT") > END_S - 10


def test_an_unchanged_stream_sends_nothing_after_its_first_report(runs: tuple[Run, Run]) -> None:
    _, ideal = runs
    sent = Counter(m.get_type() for _, m in ideal.heard)
    assert sent["ATTITUDE"] < 100  # while it turns and moves; then nothing for hours at 1 Hz
    assert _in(ideal, REST, "ATTITUDE") == [] and _in(ideal, AT_HOME_FULL, "ATTITUDE") == []
    assert _in(ideal, AT_HOME_FULL, "DOCK_SLOT_STATUS") == [] and sent["DOCK_SLOT_STATUS"] == 4
    assert _in(ideal, AT_HOME_FULL) == []  # held full at home: nothing changes, nothing is said


def test_a_go_tos_positions_come_at_the_streams_period_while_moving_and_stop_at_rest(runs: tuple[Run, Run]) -> None:
    _, ideal = runs
    heard = _in(ideal, (5, 300), "GLOBAL_POSITION_INT")
    cruising = [t for t, m in heard if math.hypot(m.vx, m.vy) >= 10]  # at 10 cm/s or more
    assert len(cruising) > 50 and {b - a for a, b in pairwise(cruising)} == {US_PER_S // 2}
    positions = [t for t, _ in heard]  # slowing to a stop, a degE7 may hold for a period or two: on the grid
    assert all((t - positions[0]) % (US_PER_S // 2) == 0 for t in positions)
    assert positions[-1] < 90 * US_PER_S  # at rest well before the end of the window: none since
    home = [t for t, _ in _in(ideal, (4_000, 5_000), "GLOBAL_POSITION_INT")]
    assert home and home[0] <= 4_001 * US_PER_S  # the command at rest woke it: at once on its grid


def test_a_command_at_rest_wakes_the_streams_and_its_effects_are_reported(runs: tuple[Run, Run]) -> None:
    _, ideal = runs
    woken = _in(ideal, (4_000, 4_002))
    types = {m.get_type() for _, m in woken}
    assert {"COMMAND_ACK", "PRIMITIVE_STATUS", "GLOBAL_POSITION_INT"} <= types
    requested = _in(ideal, (1_800, 1_801), "SYS_STATUS")
    assert len(requested) == 1  # REQUEST_MESSAGE answered as ever, though nothing changed


def test_a_resting_apads_battery_is_within_a_step_of_what_a_report_every_period_says(runs: tuple[Run, Run]) -> None:
    _, ideal = runs
    assert ideal.battery_stale == []
    drained = [m.voltage_battery for _, m in _in(ideal, REST, "SYS_STATUS")]
    charged = [m.voltage_battery for _, m in _in(ideal, (4_100, 6_000), "SYS_STATUS")]
    # 25 min at 0.5 V/h: 208 mV, a report in each 10-mV step it passes (and where its percentage changes)
    sent = [(m.voltage_battery // BATTERY_STEP_MV, m.battery_remaining) for _, m in _in(ideal, REST, "SYS_STATUS")]
    assert 20 <= len(drained) <= 25 and drained == sorted(drained, reverse=True)
    assert all(a != b for a, b in pairwise(sent)) and len({step for step, _ in sent}) >= 20
    assert len(charged) > 20 and charged[-1] == round(BATTERY_FULL_V * 1000)


def test_an_hour_at_rest_fires_few_tasks_of_the_apad(runs: tuple[Run, Run]) -> None:
    lockstep, ideal = runs
    lo, hi = REST[0] * US_PER_S, REST[1] * US_PER_S
    per_hour = 3600 / (REST[1] - REST[0])

    def fired(run: Run) -> Counter[str]:
        return Counter(name for t, name in run.fired if lo <= t < hi)

    before, after = fired(lockstep), fired(ideal)
    reports = len(_in(ideal, REST))
    print(f"\ntasks fired per hour at rest: lockstep {sum(before.values()) * per_hour:.0f} {dict(before)}; "
          f"ideal link {sum(after.values()) * per_hour:.0f} {dict(after)}; reports {reports * per_hour:.0f}")
    assert set(after) <= {"apad1.SYS_STATUS", "apad1.BATTERY_STATUS"}  # the battery alone changes
    assert sum(after.values()) == reports  # each firing reports a change: none is spent on a repeat
    assert sum(after.values()) * 5 < sum(before.values())
    assert [n for t, n in ideal.fired if AT_HOME_FULL[0] * US_PER_S <= t] == []  # held full: nothing runs


def test_the_failsafe_never_acts_without_gcs_heartbeats(runs: tuple[Run, Run]) -> None:
    _, ideal = runs
    assert ideal.failsafe_holds == 0
    assert [n for _, n in ideal.fired if n == "apad1.failsafe"] == []  # its deadline never even woke


def _going_flat(ideal: bool) -> tuple[list[tuple[int, Any]], list[tuple[int, str]]]:
    """An aPad resting away from home as its battery goes flat (0.5 V/h: 0.02 V in 144 s); SYS_STATUS,
    BATTERY_STATUS and VFR_HUD at 1 Hz. What the GCS heard (and when), and the aPad's task firings."""
    apad_end, gcs_end = memory_pair()
    clock = VirtualClock(Scheduler())
    vehicle = SitlVehicle(apad_end, ApadParams(), *HOME, ideal_link=ideal,
                          rates_hz={SYS: 1.0, BATT: 1.0, mavlink.MAVLINK_MSG_ID_VFR_HUD: 1.0})
    vehicle.state = VehicleState(x_m=20.0, y_m=0.0, battery_v=10.52)
    gcs = Codec(250, 190)
    heard: list[tuple[int, Any]] = []
    fired: list[tuple[int, str]] = []
    vehicle.attach(clock.scheduler)
    for task in clock.scheduler.tasks:
        task.callback = _counted(task.callback, task.name, fired)

    def reader(now_us: int) -> None:
        heard.extend((now_us, m) for data in gcs_end.receive() for m in gcs.decode(data))

    clock.scheduler.every(0.1, reader, "gcs-ear")
    clock.sleep(600.0)
    vehicle.close()
    return heard, fired


def test_a_battery_going_flat_at_rest_is_reported_as_lockstep_reports_it_then_nothing_runs() -> None:
    (lockstep, _), (ideal, fired) = _going_flat(False), _going_flat(True)
    assert _by_exception(ideal) == _by_exception(lockstep) and len(ideal) < len(lockstep) / 10
    health = [(t, m.onboard_control_sensors_health & mavlink.MAV_SYS_STATUS_SENSOR_BATTERY) for t, m in ideal
              if m.get_type() == "SYS_STATUS"]
    assert health[0][1] and not health[-1][1] and 140 * US_PER_S < health[-1][0] < 150 * US_PER_S  # flat at 144 s
    assert [n for t, n in fired if t > 150 * US_PER_S] == []  # flat: nothing more will change, nothing runs
