"""`vil gcs --modem` on a real pty against `vil modem` (a real process), its simulated aMussels' modems on
`vil modem --sea`'s water over real UDP: the console heard through the serial unit, called up through it,
and the called aMussel rose. Wall clock (the unit keeps real time); driven headless with Pilot.

The whole 40-minute mission is the closing note's must-show run; here its first minute, to the first
acknowledged call-up. The refusals of the flags are one line each.
"""

from __future__ import annotations

import asyncio
import signal
import subprocess
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import pytest
from testkit import free_udp_port, start_vil_modem
from tui_helpers import wait_for

from gcs.cli.main import main
from gcs.console.app import QUIT_BOUND_S, LiveConsole
from gcs.console.runner import ConsoleConfig, ConsoleRunner
from gcs.scenario.reader import load_scenario
from mussel_sim.vocabulary import MusselState

pytestmark = [pytest.mark.sitl, pytest.mark.tui]

CALLED_BOUND_S = 120.0  # wall seconds to the first call-up acknowledged: the first plan, the aPad's slot (17 s)


@pytest.fixture()
def sea_modem() -> Iterator[tuple[str, str, subprocess.Popen[str]]]:
    sea = f"udp:127.0.0.1:{free_udp_port()}"
    device, proc = start_vil_modem("--scenario", "pool12-acoustic", "--sea", sea)
    yield device, sea, proc
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        proc.communicate(timeout=30)


def test_the_gcs_hears_and_calls_up_through_a_serial_unit(
        sea_modem: tuple[str, str, subprocess.Popen[str]], tmp_path: Path) -> None:
    device, sea, proc = sea_modem
    shipped = load_scenario("missions/pool12-acoustic.toml")
    # A pool of one: the first candidate heard is called up (the shipped 4 idle the first 10 s of wall time).
    scenario = replace(shipped, mission=replace(shipped.mission, min_pool=1))
    runner = ConsoleRunner(ConsoleConfig(scenario, sitl="memory",
                                         modem=device, sea=sea, out_dir=tmp_path / "run"))
    app = LiveConsole(runner)

    def called() -> bool:
        return runner.world is not None and any(e.kind == "call_up" and e.fields.get("acked")
                                                for e in list(runner.world.events.events))

    def rising(mussel: int) -> bool:
        snap = runner.snapshot
        return snap is not None and any(int(m) == mussel and int(st) != MusselState.ACTIVE
                                        for m, st in zip(snap.mussel_ids, snap.state, strict=True))

    async def drive() -> None:
        async with app.run_test(size=(150, 46)) as pilot:
            await wait_for(pilot, called, timeout_s=CALLED_BOUND_S)
            assert runner.world is not None
            mussel = next(int(e.fields["mussel"]) for e in list(runner.world.events.events) if e.kind == "call_up")
            await wait_for(pilot, lambda: rising(mussel), timeout_s=30.0)  # WiFi at the surface shows it
            await pilot.press("Q")  # quit now: at the loop's next wait (q would dock the aMussel first)
            await wait_for(pilot, runner.finished.is_set, timeout_s=QUIT_BOUND_S + 5.0)

    asyncio.run(drive())
    assert runner.world is not None and runner.world.acoustic is not None
    acoustic = runner.world.acoustic
    uplink, call_ups, modems = acoustic.uplink, acoustic.call_ups, acoustic.modems
    assert modems.counts["reports_sent"] > 0
    assert uplink.counts["reports_heard"] >= modems.counts["reports_sent"] - 2  # a pool: all heard but the last few
    assert call_ups.counts["call_ups_acked"] >= 1 and modems.counts["heard:unicast_ack"] >= 1
    assert not uplink.dropped and not uplink.driver.dropped
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 0 and "heard" in err  # the emulator's unit heard the reports on its water


@pytest.mark.parametrize(("argv", "said"), [
    (["--sitl", "--modem", "/dev/null"], "--modem needs a scenario with [acoustic] enabled"),
    (["--sitl", "--scenario", "missions/pool12-acoustic.toml", "--modem", "/dev/null", "--speed", "10"],
     "--modem runs in real time"),
    (["--sitl", "--scenario", "missions/pool12-acoustic.toml", "--modem", "/dev/null", "--sea", "tcp:x:1"],
     "--sea: 'tcp:x:1' is not udp:HOST:PORT"),
    (["--sitl", "--sea", "udp:127.0.0.1:9"], "--sea needs --modem"),
])
def test_modem_flags_are_refused_in_one_line(argv: list[str], said: str, capsys: pytest.CaptureFixture[str],
                                             tmp_path: Path) -> None:
    assert main(["gcs", *argv, "--out", str(tmp_path / "run")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"vil gcs: {said}") and err.count("\n") == 1
    assert not (tmp_path / "run").exists()
