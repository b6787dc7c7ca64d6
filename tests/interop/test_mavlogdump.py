"""pymavlink's own `mavlogdump.py` reads the .tlogs our GCS link and the SITL aPad write.

    python -m mavlink_dialect.run_with_dialect mavlogdump.py --dialect subcultron LOG.tlog

One short real session writes both logs: `vil sitl --log-dir` records what the aPad sent, our
`gcs.link.router.Link` (tlog_path=) records everything that crossed it, including what a local party
(the simulated aMussel fleet) published. The dump must name our messages and carry their fields.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import pytest
from interop_procs import HOME, Procs
from testkit import free_udp_port

from apad_sitl.vocabulary import Primitive
from gcs.link.router import Link
from mavlink_dialect import Codec, mavlink, open_transport
from missiontime import WallClock
from mussel_sim.comms import FLEET_COMPONENT_ID, FLEET_SYSTEM_ID
from mussel_sim.vocabulary import MusselState

pytestmark = [pytest.mark.interop, pytest.mark.slow]

OURS = "AMUSSEL_STATUS,PRIMITIVE_STATUS,DOCK_SLOT_STATUS"
STATUS = {
    "time_us": 987_654_321,
    "mussel_id": 24,
    "lat": round((HOME[0] + 0.00005) * 1e7),
    "lon": round((HOME[1] + 0.00005) * 1e7),
    "depth": 2.5,  # exact in float32
    "battery": 0.5,
    "battery_voltage": 3900,
    "state": int(MusselState.ACTIVE),
    "simulated": 1,
}
TARGET_E7 = (round((HOME[0] + 0.00003) * 1e7), round((HOME[1] - 0.00004) * 1e7))


def record_a_session(procs: Procs, sitl_logs: Path, gcs_tlog: Path) -> None:
    port = free_udp_port()
    sitl = procs.sitl("--listen", f"udp:127.0.0.1:{port}", log_dir=sitl_logs)
    clock = WallClock()
    link = Link(clock, tlog_path=gcs_tlog, tlog_epoch_us=int(time.time() * 1e6))
    link.add_transport(open_transport(f"udp:127.0.0.1:{port}"))
    try:
        link.wait_vehicle(timeout_s=5.0, system_id=1)
        fleet = link.attach(None)
        fleet.send(Codec(FLEET_SYSTEM_ID, FLEET_COMPONENT_ID).encode(mavlink.MAVLink_amussel_status_message(**STATUS)))
        link.commands.send_int(1, mavlink.MAV_CMD_DO_REPOSITION, mavlink.MAV_FRAME_GLOBAL_INT, (-1.0, 1.0, 0.0, 0.0),
                         *TARGET_E7)
        clock.sleep(1.2)  # the Go To's PRIMITIVE_STATUS and a full round of DOCK_SLOT_STATUS
    finally:
        link.close()
    assert sitl.stop() == 0  # SIGTERM: the SITL closes (flushes) its logs


def dump_json(procs: Procs, log: Path) -> list[dict[str, Any]]:
    done = procs.run_with_dialect("mavlogdump.py", "--dialect", "subcultron", "--format", "json", "--types", OURS,
                                  str(log))
    return [json.loads(line) for line in done.stdout.splitlines() if line.startswith("{")]


def check_apad_messages(records: list[dict[str, Any]], t_from: float, t_to: float) -> None:
    by_type: dict[str, list[dict[str, Any]]] = {}
    for r in records:
        by_type.setdefault(r["meta"]["type"], []).append(r["data"])
        assert t_from <= r["meta"]["timestamp"] <= t_to  # .tlog stamps are Unix time, as mavlogdump reads them
    gotos = [p for p in by_type["PRIMITIVE_STATUS"] if p["primitive"] == Primitive.GOTO]
    assert gotos, by_type["PRIMITIVE_STATUS"]
    assert (gotos[0]["target_lat"], gotos[0]["target_lon"]) == TARGET_E7  # echoed exactly as commanded
    assert {s["slot"] for s in by_type["DOCK_SLOT_STATUS"]} == {1, 2, 3, 4}
    assert all(s["mussel_id"] == 0 and s["latch"] == 0 for s in by_type["DOCK_SLOT_STATUS"])


def test_mavlogdump_reads_the_gcs_and_sitl_tlogs_with_our_dialect(procs: Procs, tmp_path: Path) -> None:
    sitl_logs, gcs_tlog = tmp_path / "sitl", tmp_path / "gcs.tlog"
    t_from = time.time() - 1.0
    record_a_session(procs, sitl_logs, gcs_tlog)
    t_to = time.time() + 1.0
    (sitl_tlog,) = sitl_logs.glob("*.tlog")

    sitl_records = dump_json(procs, sitl_tlog)
    check_apad_messages(sitl_records, t_from, t_to)

    gcs_records = dump_json(procs, gcs_tlog)
    check_apad_messages(gcs_records, t_from, t_to)
    (mussel,) = [r["data"] for r in gcs_records if r["meta"]["type"] == "AMUSSEL_STATUS"]
    assert mussel == STATUS

    # The human-readable dump a field engineer greps, with who sent what.
    text = procs.run_with_dialect("mavlogdump.py", "--dialect", "subcultron", "--show-source", "--types", OURS,
                                  str(gcs_tlog)).stdout
    fields = ", ".join(f"{k} : {v}" for k, v in STATUS.items())
    assert f"AMUSSEL_STATUS {{{fields}}} srcSystem={FLEET_SYSTEM_ID} srcComponent={FLEET_COMPONENT_ID}" in text
    assert "PRIMITIVE_STATUS {" in text and "srcSystem=1 srcComponent=1" in text
    assert "UNKNOWN" not in text
