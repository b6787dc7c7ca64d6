"""`vil gcs --signing-key` (or $VIL_SIGNING_KEY): the console's link to a real signing `vil sitl` process is signed."""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from testkit import free_udp_port

from gcs.cli.console import add_gcs_arguments, run_gcs
from gcs.console.runner import ConsoleConfig, open_world
from gcs.scenario.reader import load_scenario
from mavlink_dialect import signing

pytestmark = [pytest.mark.sitl, pytest.mark.slow]

PASSPHRASE = "biograd 2020"
KEY = signing.key_from_passphrase(PASSPHRASE)


def parse(*argv: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="vil gcs")
    add_gcs_arguments(parser)
    return parser.parse_args(argv)



def test_vil_gcs_has_a_signing_key_option_and_a_bad_file_is_one_line_and_exit_2(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    key_file = tmp_path / "key"
    key_file.write_text(PASSPHRASE + "\n")
    assert parse("--sitl", "--signing-key", str(key_file)).signing_key == key_file
    args = parse("--sitl", "--signing-key", str(tmp_path / "missing"), "--out", str(tmp_path / "out"))
    assert run_gcs(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("vil gcs: cannot read signing key file")


def console_session(port: int, out: Path, key: bytes | None) -> tuple[int, int]:
    """A console world against the aPad at `port` for a few seconds; (aPads heard, GCS bad data)."""
    world = open_world(ConsoleConfig(load_scenario("pool12"), connect=f"udp:127.0.0.1:{port}", out_dir=out,
                                     signing_key=key))
    try:
        world.clock.sleep(3.0)
        return len(world.link.vehicles), world.link.bad_data
    finally:
        world.close()


def test_the_console_signs_its_link_to_a_signing_sitl_process(tmp_path: Path) -> None:
    port = free_udp_port()
    env = {**os.environ, signing.KEY_ENV: PASSPHRASE}
    proc = subprocess.Popen([sys.executable, "-m", "gcs.cli", "sitl", "--listen", f"udp:127.0.0.1:{port}",
                             "--log-dir", str(tmp_path / "apad"), "--duration", "60s"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, text=True)
    try:
        assert proc.stdout is not None and "listening on" in proc.stdout.readline()
        heard, bad = console_session(port, tmp_path / "signed", KEY)
        assert heard == 1 and bad == 0
    finally:
        proc.terminate()
        proc.communicate(timeout=10)
    [link] = [json.loads(x) for x in (tmp_path / "apad" / "apad1.events.jsonl").read_text().splitlines()
              if '"event":"link"' in x]
    # Everything the console sent (heartbeats, rate requests, the fleet's AMUSSEL_STATUS) was signed.
    assert link["received"] > 0 and link["signing_refused"] == {}
