"""Acoustic missions end to end in lockstep: the real SITL aPad over real MAVLink bytes, the fleet's
modems and the GCS's driver over the emulator's serial bytes, the channel deciding what arrives.

What is held: the GCS hears a submerged aMussel only through its TDMA reports (no AMUSSEL_STATUS
from under water in the GCS's .tlog), plans on what it heard (a sea where nothing carries gets no
call-up at all, though the truth has aMussels to charge), and on a noisy channel call-ups are
retried, reports lost and counted, knowledge ages, and still nothing is lost.
"""

from __future__ import annotations

import contextlib
import json
import re
import shutil
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from testkit import restored_session, scenario_variant

from acoustic.channel import Medium, Transmission
from acoustic.nanomodem.emulator import LOCAL, Frame, FrameKind
from gcs.cli.report import write_report
from gcs.link.faultproxy import LinkFaults
from gcs.mission import checkpoint
from gcs.mission.headless import run_mission
from gcs.mission.world import LinkOptions
from gcs.records.playback import read_events, read_tlog
from gcs.records.run_folder import RunFolder
from gcs.results.run_result import RunResult
from gcs.scenario.reader import Scenario, load_scenario
from gcs.scenario.tdma_frame import scenario_frame
from mavlink_dialect import mavlink
from mussel_sim.comms import SURFACE_DEPTH_M

Run = tuple[Scenario, RunResult, Path]
POOL = load_scenario("missions/pool12-acoustic.toml")


def acoustic_run(tmp_path: Path, minutes: float, **channel: float) -> Run:
    scenario = replace(POOL.with_overrides(duration_s=60.0 * minutes), acoustic=replace(POOL.acoustic, **channel))
    result = run_mission(scenario, tmp_path / "run")
    return scenario, result, Path(result.out_dir)


class _Copied(Exception):
    """The run into `whole` stops once its folder is copied (nobody reads the rest of it)."""


def run_copied_at_a_checkpoint(scenario: Scenario, whole: Path, crashed: Path, at_s: float,
                               monkeypatch: pytest.MonkeyPatch, to_the_end: bool = True) -> int:
    """Run `scenario` into `whole` (to its end, or without `to_the_end` only until the copy), and copy its
    folder to `crashed` as a crash right after its first checkpoint at or past `at_s` leaves it; that
    checkpoint's mission time (us)."""
    real_save, taken = checkpoint.save, []

    def save_and_copy(files: checkpoint.CheckpointFiles, ckpt: checkpoint.Checkpoint) -> None:
        real_save(files, ckpt)
        if ckpt.time_us >= at_s * 1e6 and not taken:
            taken.append(ckpt.time_us)
            shutil.copytree(whole, crashed)
            if not to_the_end:
                raise _Copied

    monkeypatch.setattr(checkpoint, "save", save_and_copy)
    with contextlib.suppress(_Copied):
        run_mission(scenario, whole)
    monkeypatch.setattr(checkpoint, "save", real_save)
    assert taken
    return taken[0]


def resumed_and_whole(scenario: Scenario, tmp_path: Path, at_s: float,
                      monkeypatch: pytest.MonkeyPatch) -> tuple[dict[str, Any], dict[str, Any]]:
    """result.json of `scenario` crashed past `at_s` and resumed (`vil run --resume`'s way: replayed to
    the checkpoint), and of the same run never interrupted; their wall time and folder left out."""
    whole, crashed = tmp_path / "whole", tmp_path / "crashed"
    run_copied_at_a_checkpoint(scenario, whole, crashed, at_s, monkeypatch)
    run_mission(scenario, crashed, resume=True)
    a, b = (json.loads((d / "result.json").read_text()) for d in (crashed, whole))
    for r in (a, b):
        del r["wall_s"], r["out_dir"]
    return a, b


def run_restored(scenario: Scenario, crashed: Path) -> RunResult:
    """The console's way back in process (`testkit.restored_session`), run to the mission's end."""
    session = restored_session(scenario, crashed)
    try:
        assert session.start()
        session.run()
        result = session.result(0.0)
        session.finish()
    finally:
        session.close()
        session.world.close()
    return result


@pytest.fixture(scope="module")
def noisy(tmp_path_factory: pytest.TempPathFactory) -> Run:
    # Ambient noise 54 dB over the default: about a third of the reports across the pool are lost.
    return acoustic_run(tmp_path_factory.mktemp("noisy"), 20.0, noise_psd_db=104.0)


def test_the_gcs_hears_submerged_amussels_only_through_their_tdma_reports(noisy: Run) -> None:
    scenario, result, folder = noisy
    statuses = [msg for _, msg in read_tlog(folder / "gcs.tlog")
                if msg.get_msgId() == mavlink.MAVLINK_MSG_ID_AMUSSEL_STATUS]
    assert statuses, "docked and floating aMussels still speak over WiFi"
    assert max(m.depth for m in statuses) <= SURFACE_DEPTH_M
    a = result.acoustic
    frame = scenario_frame(scenario)
    assert a["frame_s"] == pytest.approx(frame.frame_s, abs=1e-3)
    assert len(a["slots"]) == len(frame.slots) == 13  # 12 aMussels and the aPad
    assert 0 < a["counts"]["reports_heard"] < a["fleet"]["reports_sent"]  # heard, and lost on the water
    assert a["channel"]["packet_error"] > 0


def test_call_ups_are_retried_on_a_noisy_channel_and_nothing_is_lost(noisy: Run) -> None:
    _, result, folder = noisy
    counts = result.acoustic["counts"]
    assert counts["call_up_retries"] > 0
    assert counts["call_up_sent"] == counts["call_ups_acked"] + counts["call_up_retries"] + 3 * counts.get(
        "call_ups_unacked", 0)
    called = [e for e in read_events(folder / "events.jsonl") if e.kind == "call_up"]
    assert called and all(e.fields["acoustic"] for e in called)
    assert result.cycles >= 1 and not result.misplaced
    assert all(m.state_s.get("depleted", 0.0) == 0.0 for m in result.mussels)


def test_knowledge_ages_with_the_frame_and_the_estimate_tracks_the_truth(noisy: Run) -> None:
    scenario, result, _ = noisy
    k = result.acoustic["knowledge"]
    frame_s = scenario_frame(scenario).frame_s
    assert k["samples"] == pytest.approx(20 * 60 / 10, abs=2)
    assert 0.0 < k["age_median_s"] < frame_s  # at the surface an aMussel is heard every second
    assert k["age_max_s"] > frame_s  # a report lost: the next is a frame later
    # Run down by eq. (1) between reports, the belief stays within a percent of the battery on average.
    assert 0.0 < k["battery_error_mean"] < 0.01
    assert {p["mussel_id"] for p in k["per_mussel"]} == set(range(1, 13))


def test_a_sea_that_carries_nothing_gets_no_call_up_though_the_truth_has_amussels_to_charge(tmp_path: Path) -> None:
    # A source level so low that no packet reaches anyone: the GCS never hears a submerged aMussel.
    scenario, result, folder = acoustic_run(tmp_path, 10.0, source_level_db=60.0)
    low = [m for m in result.mussels if m.start_battery < scenario.mission.pool_threshold]
    assert len(low) >= scenario.mission.min_pool  # the paper's GCS would have set off at once
    assert result.acoustic["counts"].get("reports_heard", 0) == 0
    assert result.acoustic["channel"]["delivered"] == 0
    assert not [e for e in read_events(folder / "events.jsonl") if e.kind == "call_up"]
    assert result.cycles == 0 and result.cost_m == 0.0


def test_a_sleeping_amussel_is_pinged_awake_before_its_call_up(tmp_path: Path) -> None:
    # Eight aMussels on the hourly-wake profile in the bay: each is heard only after a wake, and the
    # GCS pings one awake (the wake-up ping) before it calls it up: woken, it takes the call-up at once
    # and rises, instead of waiting for its next scheduled wake (every 120 s of mission time here).
    path = scenario_variant("bay-capacity", tmp_path / "sleepers.toml", {
        "count = 8": 'count = 8\nprofile = "hourly_wake"',
        "start_battery = [0.6, 1.0]": "start_battery = [0.05, 0.2]",
        'duration = "40m"': 'duration = "30m"',
    })
    scenario = load_scenario(path)
    scenario = replace(scenario, acoustic=replace(scenario.acoustic, enabled=True))
    result = run_mission(scenario, tmp_path / "run")
    counts, fleet = result.acoustic["counts"], result.acoustic["fleet"]
    assert fleet["silent:asleep"] > 0  # asleep in most of its slots
    assert counts["wake_pings"] > 0 and fleet["heard:ping"] > 0
    assert fleet["heard:unicast_ack"] > 0 and result.cycles >= 1 and not result.misplaced
    traces = np.load(Path(result.out_dir) / "traces.npz")
    row = {int(m): k for k, m in enumerate(traces["ids"])}
    step_s = traces["step_time_us"] / 1e6
    names = [str(n) for n in traces["state_names"]]
    acked = [e for e in read_events(Path(result.out_dir) / "events.jsonl") if e.kind == "call_up" and e.fields["acked"]]
    assert acked
    for e in acked:  # the step after the acknowledgement, it is on its way up (or up already)
        after = int(np.searchsorted(step_s, e.t_s + 2.0))
        assert names[int(traces["battery_state"][after, row[e.fields["mussel"]]])] != "active", e


def test_the_report_shows_belief_against_truth(noisy: Run, tmp_path: Path) -> None:
    _, result, folder = noisy
    write_report(folder, tmp_path / "report")
    page = (tmp_path / "report" / "index.html").read_text()
    section = page[page.index('id="knowledge"'):page.index('id="figures"')]
    heard = result.acoustic["counts"]["reports_heard"]
    assert f"{heard:,} of {result.acoustic['fleet']['reports_sent']:,} status reports heard" in section
    rows = re.findall(r"<tr[^>]*><td class=\"text\">(\d+)</td>", section)
    assert sorted(int(m) for m in rows) == list(range(1, 13))  # one row of belief against truth per aMussel


def test_a_crashed_acoustic_mission_resumes_to_the_uninterrupted_result(tmp_path: Path,
                                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    # The folder as a crash at the first checkpoint past 5 minutes leaves it; the resume replays the
    # mission to that checkpoint (the channel's draws included) and goes on.
    scenario = replace(POOL.with_overrides(duration_s=600.0), acoustic=replace(POOL.acoustic, noise_psd_db=104.0))
    a, b = resumed_and_whole(scenario, tmp_path, 300.0, monkeypatch)
    assert a["acoustic"]["counts"]["reports_heard"] > 0 and a["acoustic"]["channel"]["packet_error"] > 0
    assert a == b


def test_an_acoustic_mission_restored_from_a_checkpoint_hears_on_and_loses_nothing(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # The console's way back (`vil gcs --resume`): the checkpoint's state put into a fresh world, no
    # replay. The acoustic network starts afresh (a new frame from the resume, the emulator's water
    # empty) on what the restored registry last heard: it must hear on, call up on, and lose nothing.
    scenario = POOL.with_overrides(duration_s=900.0)  # restored while charging, the next collection after
    whole, crashed = tmp_path / "whole", tmp_path / "crashed"
    saved_us = run_copied_at_a_checkpoint(scenario, whole, crashed, 240.0, monkeypatch, to_the_end=False)
    result = run_restored(scenario, crashed)
    a = result.acoustic
    resumed_s = 900.0 - saved_us / 1e6
    assert result.end_reason == "mission time" and result.misplaced == []
    frames = resumed_s / scenario_frame(scenario).frame_s
    assert a["counts"]["reports_heard"] > 0.8 * frames * 6  # at least half the fleet heard in each frame
    assert a["counts"]["call_up_sent"] > 0 and a["counts"]["call_ups_acked"] == a["counts"]["call_up_sent"]
    k = a["knowledge"]
    assert k["samples"] == pytest.approx(resumed_s / 10, abs=2)
    assert k["age_max_s"] < 2 * scenario_frame(scenario).frame_s and k["battery_error_max"] < 0.01


def test_a_restored_mission_plans_on_the_sleep_orders_sent_before_the_crash(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # keep_alive puts four aMussels to sleep at 439 s (seed 1). Restored at 600 s, the loop must know
    # them asleep: believed run down at the sleep order's drain from where it was believed when the
    # order went (not the always-on profile's, 14x faster), and not ordered to sleep a second time.
    scenario = POOL.with_overrides(strategy="keep_alive")  # the 40 minutes: a shorter mission orders fewer
    whole, crashed = tmp_path / "whole", tmp_path / "crashed"
    run_copied_at_a_checkpoint(scenario, whole, crashed, 600.0, monkeypatch, to_the_end=False)
    saved = checkpoint.CheckpointFiles(RunFolder(crashed).checkpoint).read()
    asleep = {m for m, duty in saved.loop_statuses[1].orders.duties.items() if duty.asleep}
    assert len(asleep) >= 2 and set(saved.loop_statuses[1].orders.changed) >= asleep
    result = run_restored(scenario, crashed)
    assert result.end_reason == "mission time" and result.misplaced == []
    assert result.acoustic["knowledge"]["battery_error_max"] < 0.01
    orders = [e.fields for e in read_events(RunFolder(crashed).events) if e.kind == "sleep_order"]
    assert len(orders) > len(asleep)  # some after the restore too
    last: dict[int, float] = {}
    for order in orders:  # before the crash and after the restore: never the same order twice in a row
        assert last.get(order["mussel"]) != order["interval_s"], order
        last[order["mussel"]] = order["interval_s"]


POOL_X2 = load_scenario("missions/pool12x2.toml")


def two_apad_acoustic(minutes: float) -> Scenario:
    """pool12x2 (two aPads, one at each end of the pool) with the sea between them."""
    return replace(POOL_X2.with_overrides(duration_s=60.0 * minutes), acoustic=replace(POOL_X2.acoustic, enabled=True))


def test_two_apads_share_the_fleet_as_it_is_heard_and_call_up_over_the_water(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # At the start the GCS has heard no aMussel: the fleet is shared among the aPads as each is first
    # heard in its TDMA slot (the nearest aPad with room), and each aPad calls up through its own unit,
    # from where it is: every ping and call-up on the water leaves from an aPad's unit, as far from
    # its aMussel as the call-up's event says the aPad was (the GCS's unit, at one end of the pool,
    # is tens of metres from the aMussels at the other).
    sent: list[tuple[int, FrameKind, np.ndarray, np.ndarray]] = []
    transmit = Medium.transmit

    def recorded(self: Medium, sender: int, start_s: float, payload_bytes: int, data: object = None,
                 listeners: list[int] | None = None) -> Transmission:
        if isinstance(data, Frame) and data.kind in (FrameKind.PING, FrameKind.UNICAST_ACK) and listeners:
            sent.append((sender, data.kind, self.positions_m[sender].copy(), self.positions_m[listeners[0]].copy()))
        return transmit(self, sender, start_s, payload_bytes, data, listeners)

    monkeypatch.setattr(Medium, "transmit", recorded)
    result = run_mission(two_apad_acoustic(20.0), tmp_path / "run")
    events = read_events(Path(result.out_dir) / "events.jsonl")
    shares = {row["sysid"]: row["mussels"] for row in result.apads}
    assert sorted(shares[1] + shares[2]) == list(range(1, 13)) and len(shares[1]) == len(shares[2]) == 6
    joined = [e.fields["shares"] for e in events if e.kind == "joined"]
    assert sorted(m for j in joined for ids in j.values() for m in ids) == list(range(1, 13))  # each joined once
    called = [e.fields for e in events if e.kind == "call_up"]
    assert {c["apad"] for c in called} == {1, 2}
    assert all(c["acoustic"] and c["acked"] and c["mussel"] in shares[c["apad"]] for c in called)
    counts = result.acoustic["counts"]
    assert counts["call_up_sent"] == counts["call_ups_acked"] == counts["call_ups_from_apad_unit"] == len(called)
    call_ups = [(node, at, to) for node, kind, at, to in sent if kind is FrameKind.UNICAST_ACK]
    assert len(call_ups) == len(called) and all(node != LOCAL for node, _, _ in call_ups)
    gaps = [abs(float(np.hypot(*(at - to)[:2])) - c["distance_m"])
            for (_, at, to), c in zip(call_ups, called, strict=True)]
    assert max(gaps) < 1.0, gaps  # through the GCS's unit: up to 13 m
    assert len(result.acoustic["slots"]) == 14  # 12 aMussels and the 2 aPads
    k = result.acoustic["knowledge"]
    assert {p["mussel_id"] for p in k["per_mussel"]} == set(range(1, 13)) and k["battery_error_max"] < 0.01
    assert result.misplaced == [] and all(m.state_s.get("depleted", 0.0) == 0.0 for m in result.mussels)


def test_a_crashed_two_apad_acoustic_mission_resumes_to_the_uninterrupted_result(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # Killed past 5 minutes on a noisy channel (call-ups retried, reports lost): the resume replays both
    # loops, the shared unit and the channel's draws to the checkpoint and goes on to the same result.
    scenario = two_apad_acoustic(10.0)
    scenario = replace(scenario, acoustic=replace(scenario.acoustic, noise_psd_db=104.0))
    a, b = resumed_and_whole(scenario, tmp_path, 300.0, monkeypatch)
    assert a["acoustic"]["counts"]["call_up_retries"] > 0 and a["acoustic"]["channel"]["packet_error"] > 0
    assert {e["sysid"] for e in a["apads"]} == {1, 2} and a == b


def test_call_ups_through_the_apads_modem_survive_a_lossy_wifi_link(tmp_path: Path) -> None:
    # The call-ups cross the aPad's MAVLink now (APAD_MODEM_SERIAL). On docs/faults.md's field WiFi
    # (20 % loss each way, 200 ms, 5 % duplicates) writes go to the modem once and its output comes back
    # whole, so every call-up is acknowledged: before the passthrough numbered its writes and sent its
    # output again until confirmed, 7 of 8 at 20 % loss, and duplicates put call-ups twice on the water.
    scenario = POOL.with_overrides(duration_s=1200.0)
    faults = LinkFaults(loss_frac=0.20, latency_s=0.200, duplicate_frac=0.05, seed=1)
    result = run_mission(scenario, tmp_path / "run", options=LinkOptions(faults=faults))
    counts = result.acoustic["counts"]
    assert counts["call_ups_acked"] == counts["call_ups_from_apad_unit"] > 0 and "call_ups_unacked" not in counts
    unit = result.acoustic["apad_units"]["1"]
    assert unit["dropped"]["request_unanswered"] > 0  # lost on the way, asked again
    assert result.misplaced == []
