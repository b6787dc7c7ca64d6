"""MAVProxy 1.8.75, headless, with our dialect through `mavlink_dialect.run_with_dialect`, against `vil sitl`.

The command line that works (commands on stdin, EOF ends it; MAVProxy always exits 1):

    vil sitl --listen udp:127.0.0.1:P
    python -m mavlink_dialect.run_with_dialect mavproxy.py --master=udpout:127.0.0.1:P --mav20 \\
        --no-state --dialect subcultron --default-modules=link,param,arm,mode,cmdlong,misc

What MAVProxy prints is checked against an independent observer: our own `gcs.link.router.Link` as a
second UDP client of the same SITL (a listening SITL answers every peer it has heard), and the
SITL's event log.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest
from interop_procs import Procs, read_events
from testkit import free_udp_port

from apad_sitl.params import PARAMS
from apad_sitl.vocabulary import Primitive
from gcs.link.router import Link
from mavlink_dialect import mavlink, open_transport
from missiontime import WallClock

pytestmark = [pytest.mark.interop, pytest.mark.slow]

MAVPROXY_MODULES = "link,param,arm,mode,cmdlong,misc"
GUIDED_TARGET = (43.94005, 15.44002)  # ~6 m from home


def wait_on(clock: WallClock, predicate: Callable[[], bool], timeout_s: float, what: str) -> None:
    """Run the link's clock until `predicate` holds."""
    deadline = clock.time() + timeout_s
    while not predicate():
        if clock.time() >= deadline:
            pytest.fail(f"our GCS link: no {what} within {timeout_s:g} s")
        clock.sleep(0.05)


def test_mavproxy_sees_the_apad_its_modes_params_and_dialect(procs: Procs, tmp_path: Path) -> None:
    port = free_udp_port()
    logs = tmp_path / "sitl"
    sitl = procs.sitl("--listen", f"udp:127.0.0.1:{port}", log_dir=logs)
    mp = procs.with_dialect(
        "mavproxy", "mavproxy.py", f"--master=udpout:127.0.0.1:{port}", "--mav20", "--no-state",
        "--dialect", "subcultron", f"--default-modules={MAVPROXY_MODULES}", stdin=True,
    )
    mp.wait_output(r"Detected vehicle 1:1", 10.0)
    mp.wait_output(r"Mode HOLD", 5.0)  # custom mode 4 of a MAV_TYPE_SURFACE_BOAT ArduPilot: Rover's HOLD
    mp.wait_output(rf"Received {len(PARAMS)} parameters", 10.0)

    # Our dialect, decoded by MAVProxy itself (without the launcher it cannot even load `subcultron`).
    mark = mp.send("status PRIMITIVE_STATUS")
    mp.wait_output(r"PRIMITIVE_STATUS \{time_us : \d+, primitive : 0, progress : 0, target_lat : 0", 3.0, mark)
    mark = mp.send("status DOCK_SLOT_STATUS")
    mp.wait_output(r"DOCK_SLOT_STATUS \{time_us : \d+, slot : [1-4], mussel_id : 0, latch : 0, charging : 0\}",
                   3.0, mark)
    mark = mp.send("param show SPEED_MAX")
    mp.wait_output(r"SPEED_MAX\s+0\.5\s*$", 3.0, mark)

    clock = WallClock()
    link = Link(clock)
    link.add_transport(open_transport(f"udp:127.0.0.1:{port}"))
    try:
        view = link.wait_vehicle(timeout_s=5.0, system_id=1)
        assert view.custom_mode == 4

        mark = mp.send("mode guided")
        mp.wait_output(r"Got COMMAND_ACK: DO_SET_MODE: ACCEPTED", 3.0, mark)
        mp.wait_output(r"Mode GUIDED", 3.0, mark)
        wait_on(clock, lambda: view.custom_mode == 15, 3.0, "GUIDED (15) in the aPad's HEARTBEAT")

        mark = mp.send(f"guided {GUIDED_TARGET[0]} {GUIDED_TARGET[1]} 0")  # COMMAND_INT DO_REPOSITION
        mp.wait_output(r"Got COMMAND_ACK: DO_REPOSITION: ACCEPTED", 3.0, mark)
        target_e7 = (round(GUIDED_TARGET[0] * 1e7), round(GUIDED_TARGET[1] * 1e7))
        wait_on(clock, lambda: view.primitive.primitive == Primitive.GOTO
                and (view.primitive.target_lat_e7, view.primitive.target_lon_e7) == target_e7,
                3.0, "PRIMITIVE_STATUS Go To the target MAVProxy sent")

        view.params.clear()
        mp.send("param set SPEED_MAX 0.8")
        # The SITL answers the PARAM_SET to every peer; ask on our own as well, in case we missed it.
        request = mavlink.MAVLink_param_request_read_message(1, mavlink.MAV_COMP_ID_AUTOPILOT1, b"SPEED_MAX", -1)
        for _ in range(6):
            if view.params.get("SPEED_MAX") == pytest.approx(0.8):
                break
            link.send(request)
            clock.sleep(0.5)
        assert view.params.get("SPEED_MAX") == pytest.approx(0.8), view.params
        mark = mp.send("param show SPEED_MAX")
        mp.wait_output(r"SPEED_MAX\s+0\.8\d*\s*$", 3.0, mark)
    finally:
        link.close()

    mp.stop()
    assert "Unloading module param" in mp.output  # a clean EOF shutdown, not a kill
    assert sitl.stop() == 0
    events = read_events(logs)
    assert [(e["name"], e["old"], e["new"]) for e in events if e["event"] == "param"] == [
        ("SPEED_MAX", 0.5, pytest.approx(0.8))
    ]
    assert [e["mode"] for e in events if e["event"] == "mode"] == ["GUIDED"]
    commands = {e["name"]: e for e in events if e["event"] == "command"}
    assert commands["MAV_CMD_DO_SET_MODE"]["params"][:2] == [1.0, 15.0]
    assert commands["MAV_CMD_DO_SET_MODE"]["source"] == [255, 230]  # MAVProxy's default source ids
    assert commands["MAV_CMD_DO_REPOSITION"]["result"] == "ACCEPTED"
    assert commands["MAV_CMD_DO_REPOSITION"]["params"][4:6] == list(target_e7)
