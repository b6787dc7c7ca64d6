"""The whole mission over real UDP sockets through the seeded fault proxy, on the virtual clock."""

from __future__ import annotations

import json
import socket
from pathlib import Path

import pytest

from apad_sitl.primitives import Refusal
from gcs.link.faultproxy import FaultProxy, LinkFaults
from gcs.mission.headless import run_mission
from gcs.mission.world import LinkOptions
from gcs.scenario.reader import load_scenario
from mavlink_dialect import MAV_CMD_APAD_UNDOCK
from missiontime import VirtualClock

pytestmark = pytest.mark.sitl

FIELD_WIFI = LinkFaults(loss_frac=0.20, latency_s=0.200, duplicate_frac=0.05, seed=1)


def test_pool12_greedy_survives_20pc_loss_200ms_latency_5pc_duplication(tmp_path: Path) -> None:
    s = load_scenario("pool12").with_overrides(strategy="greedy")
    clean = run_mission(s)
    lossy = run_mission(s, tmp_path, options=LinkOptions(faults=FIELD_WIFI))
    m = lossy.messages
    for way in ("to_apad", "to_gcs"):  # the faults really happened, both ways
        sent = m[f"proxy_{way}_forwarded"] + m[f"proxy_{way}_dropped"] - m[f"proxy_{way}_duplicated"]
        assert m[f"proxy_{way}_dropped"] / sent == pytest.approx(0.20, abs=0.02)
        assert m[f"proxy_{way}_duplicated"] / sent == pytest.approx(0.05 * 0.8, abs=0.02)
    assert lossy.end_reason == "mission time"
    assert lossy.cycles >= clean.cycles - 2 and lossy.cycles >= 3
    for r in (clean, lossy):  # nothing lost: every aMussel on the seabed near its position, or on a slot
        assert len(r.whereabouts) == 12
        assert [w for w in r.whereabouts if w["where"] == "lost"] == []
    # Duplicates were harmless: retransmissions reached the aPad and were re-ACKed, not re-executed;
    # every latch that closed is one the GCS counts as docked, every undock one it counts as released.
    apad = [json.loads(x) for x in (tmp_path / "apad1.events.jsonl").read_text().splitlines()]
    gcs = [json.loads(x) for x in (tmp_path / "events.jsonl").read_text().splitlines()]
    assert any(e["event"] == "command_retry" for e in apad)
    executed = [e for e in apad if e["event"] == "command" and e["result"] == "ACCEPTED"]
    latched = [(e["slot"], e["mussel_id"]) for e in apad if e["event"] == "slot" and e["latch"] == "LATCHED"]
    undocks = [(int(e["params"][0]), int(e["params"][1])) for e in executed if e["command"] == MAV_CMD_APAD_UNDOCK]
    assert latched == [(e["slot"], e["mussel"]) for e in gcs if e["event"] == "docked"]  # none latched twice
    assert undocks == [(e["slot"], e["mussel"]) for e in gcs if e["event"] == "released"]
    # Every undock names its aMussel, so a late duplicate can only find the slot empty, never release another.
    undock_cmds = [e for e in apad if e["event"] == "command" and e["command"] == MAV_CMD_APAD_UNDOCK]
    assert all(int(e["params"][1]) != 0 for e in undock_cmds)
    assert {e["result_param2"] for e in undock_cmds if e["result"] == "DENIED"} <= {Refusal.SLOT_EMPTY}
    # The mission still shares energy: uptime within a few points of the clean run.
    assert lossy.uptime["avg"] == pytest.approx(clean.uptime["avg"], abs=5.0)
    print(f"clean uptime {clean.uptime} cost {clean.cost_m} m; lossy uptime {lossy.uptime} cost {lossy.cost_m} m")


def test_lossy_runs_repeat_exactly_with_the_same_seed() -> None:
    s = load_scenario("pool12").with_overrides(strategy="greedy", duration_s=600.0)
    opts = LinkOptions(faults=LinkFaults(0.2, 0.2, 0.1, 0.05, seed=7))
    a, b = run_mission(s, options=opts), run_mission(s, options=opts)
    assert (a.uptime, a.cost_m, a.messages) == (b.uptime, b.cost_m, b.messages)


def _udp(port: int = 0) -> socket.socket:
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", port))
    sock.setblocking(False)
    return sock


def _drain(sock: socket.socket) -> list[bytes]:
    out = []
    while True:
        try:
            out.append(sock.recvfrom(65535)[0])
        except BlockingIOError:
            return out


def test_the_proxy_delays_in_mission_time_reorders_with_jitter_and_answers_back() -> None:
    clock = VirtualClock()
    vehicle, gcs = _udp(), _udp()
    proxy = FaultProxy(clock, vehicle.getsockname(), LinkFaults(latency_s=0.5, jitter_s=0.4, seed=2))
    for i in range(50):
        gcs.sendto(bytes([i]), ("127.0.0.1", proxy.listen_port))
    clock.sleep(0.0)
    clock.sleep(0.49)
    assert _drain(vehicle) == []  # nothing before the latency, however fast the CPU ran
    clock.sleep(0.42)
    got = [d[0] for d in _drain(vehicle)]
    assert sorted(got) == list(range(50)) and got != sorted(got)  # all there, some overtaken
    assert proxy.stats[True].reordered > 0
    vehicle.sendto(b"ack", ("127.0.0.1", proxy.vehicle_side.transport.local_port))
    clock.sleep(1.0)
    assert _drain(gcs) == [b"ack"]  # back to whoever spoke to the proxy
    proxy.close()
    vehicle.close()
    gcs.close()


def test_fault_settings_are_checked() -> None:
    with pytest.raises(ValueError, match="loss"):
        LinkFaults(loss_frac=1.0)
    with pytest.raises(ValueError, match="latency"):
        LinkFaults(latency_s=-1)
