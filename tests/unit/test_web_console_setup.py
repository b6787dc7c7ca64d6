"""`vil gcs --web`: the address, the command each browser session runs, and a page that needs no internet."""

from __future__ import annotations

import argparse
import shlex
import socket
import sys
from pathlib import Path

import pytest

from gcs.console.web import console_command, local_template, start_line, web_address


def test_the_address_binds_this_machine_only_unless_a_host_is_given() -> None:
    assert web_address("8000") == ("127.0.0.1", 8000)
    assert web_address("0.0.0.0:8000") == ("0.0.0.0", 8000)
    assert web_address("[::1]:8080") == ("::1", 8080)
    for bad in ("", "http", "0", "65536", ":8000", "host:"):
        with pytest.raises(argparse.ArgumentTypeError, match=r"expected \[HOST:\]PORT"):
            web_address(bad)


@pytest.mark.parametrize("argv", [
    ["gcs", "--sitl", "--web", "8000", "--scenario", "pool12x2"],
    ["gcs", "--web=0.0.0.0:8000", "--sitl", "--scenario", "pool12x2"],
    ["gcs", "--sitl", "--we", "8000", "--scenario", "pool12x2"],  # argparse takes abbreviations
])
def test_each_browser_session_runs_the_terminal_consoles_command_without_web(argv: list[str]) -> None:
    assert shlex.split(console_command(argv)) == [sys.executable, "-m", "gcs.cli", "gcs", "--sitl", "--scenario",
                                                  "pool12x2"]


def test_the_page_takes_its_font_from_the_installed_package_and_nothing_from_outside(tmp_path: Path) -> None:
    page = (local_template(tmp_path) / "app_index.html").read_text()
    assert "fonts.googleapis.com" not in page and "https://" not in page
    assert 'src: url("{{ config.static.url }}fonts/RobotoMono-VariableFont_wght.ttf")' in page
    import textual_serve

    fonts = Path(textual_serve.__file__).parent / "static" / "fonts"
    assert (fonts / "RobotoMono-VariableFont_wght.ttf").is_file()  # what the page names is shipped


def test_the_start_line_says_what_to_open_and_who_can_reach_it() -> None:
    assert start_line("127.0.0.1", 8000) == (
        "vil gcs: serving the console to this machine only: open http://127.0.0.1:8000/ (--web 0.0.0.0:8000 for "
        "the boat's network); one browser at a time; Ctrl+C stops")
    assert "on every network of this machine" in start_line("0.0.0.0", 8000)


def test_a_port_in_use_is_one_line_before_anything_says_it_serves(capsys: pytest.CaptureFixture[str]) -> None:
    from gcs.cli.main import main

    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        assert main(["gcs", "--sitl", "--web", str(port)]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err == f"vil gcs: --web 127.0.0.1:{port}: cannot listen: Address already in use\n"
