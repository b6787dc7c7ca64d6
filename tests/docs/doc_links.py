"""How the examples that talk MAVLink over the documented fixed ports run, and what of their claims is
checked (the registry's "links" room): a SITL aPad and Listing 1, the SITL of a swarm scenario and a
console connected to it, MAVProxy and mavlogdump through our dialect launcher. The ports (14550, 14551)
are held for the test (`ports_held`), so these run as written."""

from __future__ import annotations

import shutil

from doc_harness import Work, ports_held
from interop_procs import Procs, tool

SITL = "vil sitl --listen udp:127.0.0.1:14550"
LISTING1 = "python missions/listing1.py --connect udp:127.0.0.1:14550"
SITL_X2 = "vil sitl --scenario pool12x2"
GCS_CONNECT = "vil gcs --connect udp:127.0.0.1:14550,udp:127.0.0.1:14551 --scenario missions/pool12x2.toml"
MAVPROXY = ("python -m mavlink_dialect.run_with_dialect mavproxy.py --master=udpout:127.0.0.1:14550 --mav20 "
            "--dialect subcultron --default-modules=link,param,arm,mode,cmdlong,misc")
MAVLOGDUMP = "python -m mavlink_dialect.run_with_dialect mavlogdump.py --dialect subcultron runs/latest/gcs.tlog"
SITL_STARTED = r"^vil sitl: aPad sysid \d+ listening on udp:127\.0\.0\.1:14550"


def run_sitl_listing1(w: Work) -> None:
    """a SITL aPad listening on udp 14550, then Listing 1 against it: Go To aMussel 24's position, dock
    it into slot 2, exit 0; the aPad stops cleanly when told to (SIGTERM)."""
    with ports_held(14550):
        sitl = w.start(w.line(SITL))
        try:
            sitl.wait_output(SITL_STARTED)
            done = w.sh(w.line(LISTING1), timeout_s=120)
        finally:
            status = sitl.stop()
    lines = done.stdout.splitlines()
    assert "GoTo in progress." in lines and "Goal reached. Docking start." in lines, done.stdout
    assert lines[-1] == "Docking done: slot 2 holds aMussel 24 (LATCHED, charging).", done.stdout
    assert status == 0, sitl.output


def run_sitl_x2_and_gcs(w: Work) -> None:
    """pool12x2's SITL: aPad 1 on udp 14550 and aPad 2 on 14551, each heard at its scenario home; then
    one console connected to both shows both aPads, and quits with q."""
    from gcs.scenario.reader import load_scenario

    scenario = load_scenario(w.path / "missions" / "pool12x2.toml")
    with ports_held(14550, 14551):
        sitl = w.start(w.line(SITL_X2))
        try:
            sitl.wait_output(r"its 2 aPads at their homes")
            for port, apad in zip((14550, 14551), scenario.apads, strict=True):
                _heard_at_home(port, apad.system_id, (apad.home_lat_deg, apad.home_lon_deg))
            console = w.console(w.line(GCS_CONNECT))
            try:
                console.wait("◆ aPad 1", "◆ aPad 2", "udp:127.0.0.1:1455")
                assert console.quit() == 0, console.text()[-2000:]
            finally:
                console.close()
        finally:
            status = sitl.stop()
    assert status == 0, sitl.output
    assert "vil gcs: logs in runs/console-pool12x2-run1" in console.text()


def _heard_at_home(port: int, sysid: int, home: tuple[float, float]) -> None:
    from gcs.link.router import Link
    from mavlink_dialect import open_transport
    from missiontime import WallClock
    from mussel_sim.geo import distance_m

    clock = WallClock()
    link = Link(clock)
    link.add_transport(open_transport(f"udp:127.0.0.1:{port}"))
    try:
        view = link.wait_vehicle(timeout_s=10.0, system_id=sysid)
        deadline = clock.time() + 5.0
        while view.lat_deg is None and clock.time() < deadline:
            clock.sleep(0.05)
        assert view.lat_deg is not None and view.lon_deg is not None, f"aPad {sysid}: no position on {port}"
        away_m = float(distance_m(home[0], home[1], view.lat_deg, view.lon_deg))
        assert away_m < 1.0, (sysid, port, away_m)
        assert set(link.vehicles) == {sysid}, (port, set(link.vehicles))  # one aPad per port
    finally:
        link.close()


def run_mavproxy(w: Work) -> None:
    """MAVProxy, a stock tool, flies the SITL aPad through our dialect: it sees an ArduRover boat in HOLD
    (4), decodes our PRIMITIVE_STATUS, switches it to GUIDED (15) and sends it a Go To that it accepts."""
    tool("mavproxy.py")  # the interop extra; skipped (named) where it is not installed
    with ports_held(14550):
        sitl = w.start(w.line(SITL))
        procs = Procs(w.path)
        procs.env = w.env | {"NO_COLOR": "1", "HOME": str(w.path)}  # hermetic: no ~/.mavinit.scr of anyone's
        try:
            sitl.wait_output(SITL_STARTED)
            mp = procs.start("mavproxy", w.line(MAVPROXY).split(), stdin=True)
            mp.wait_output(r"Detected vehicle 1:1", 20.0)
            mp.wait_output(r"Mode HOLD", 10.0)
            mp.wait_output(r"Received \d+ parameters", 15.0)
            mark = mp.send("status PRIMITIVE_STATUS")
            mp.wait_output(r"PRIMITIVE_STATUS \{time_us : \d+, primitive : 0", 5.0, mark)
            mark = mp.send("mode guided")
            mp.wait_output(r"Mode GUIDED", 5.0, mark)
            mark = mp.send("guided 43.94005 15.43986 0")
            mp.wait_output(r"Got COMMAND_ACK: DO_REPOSITION: ACCEPTED", 5.0, mark)
            mp.stop()
        finally:
            procs.close()
            status = sitl.stop()
    assert "Unloading module param" in mp.output  # ended by EOF on its console, not killed
    assert status == 0, sitl.output


def run_mavlogdump(w: Work) -> None:
    """mavlogdump reads a run's GCS .tlog with our dialect: our messages by name, nothing unknown."""
    tool("mavlogdump.py")
    shutil.copytree(w.fixture("recorded_runs") / "runs", w.path / "runs", symlinks=True)
    dump = w.sh(w.line(MAVLOGDUMP), timeout_s=120).stdout
    for name in ("AMUSSEL_STATUS {", "DOCK_SLOT_STATUS {", "PRIMITIVE_STATUS {", "HEARTBEAT {"):
        assert name in dump, name
    assert "UNKNOWN" not in dump and "BAD_DATA" not in dump
