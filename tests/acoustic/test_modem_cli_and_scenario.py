"""`vil modem`'s flags, its scenario reading, and the scenario's [acoustic] table."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from acoustic.params import AcousticParams
from gcs.cli.main import main
from gcs.cli.modem import parse_nodes, scenario_units
from gcs.scenario.reader import MISSIONS_DIR, ScenarioError, load_scenario


def test_help_explains_the_protocol_and_every_flag(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as done:
        main(["modem", "--help"])
    out = capsys.readouterr().out
    assert done.value.code == 0
    for phrase in ("$Pxxx", "#TO", "9600 8N1", "--nodes", "--scenario", "--device", "--gap", "--ping-timeout",
                   "first line printed is the serial device"):
        assert phrase in " ".join(out.split()), phrase


def test_nodes_and_their_errors_are_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    units = parse_nodes(["5@300,0,5", "9@-10.5,20,2:11.1"])
    assert [(u.address, u.position_m, u.supply_v) for u in units] == [(5, (300.0, 0.0, 5.0), 12.0),
                                                                        (9, (-10.5, 20.0, 2.0), 11.1)]
    for bad in (["5@1,2"], ["300@1,2,3"], ["x"]):
        assert main(["modem", "--nodes", *bad]) == 2
        err = capsys.readouterr().err
        assert err.startswith("vil modem: --nodes:") and err.count("\n") == 1
    assert main(["modem", "--nodes", "5@1,2,3", "5@4,5,6"]) == 2
    assert "must differ" in capsys.readouterr().err
    assert main(["modem", "--scenario", "no-such-scenario"]) == 2
    assert "no such scenario file" in capsys.readouterr().err
    assert main(["modem", "--address", "5", "--nodes", "5@1,2,3"]) == 2  # it would answer for this unit
    assert "also a remote unit's address" in capsys.readouterr().err


def test_a_scenario_whose_area_file_is_gone_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    text = (MISSIONS_DIR / "pool12.toml").read_text()
    (tmp_path / "areas").mkdir()
    (tmp_path / "areas" / "pool.geojson").mkdir()  # there, but unreadable: an OSError
    (tmp_path / "starts").mkdir()
    scenario = tmp_path / "gone.toml"
    scenario.write_text(text.replace('start_config = "starts/pool12.geojson"', "").replace("#:schema", "# "))
    assert main(["modem", "--scenario", str(scenario)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("vil modem: ") and err.count("\n") == 1 and "Traceback" not in err


def test_a_scenarios_aMussels_are_the_remote_units_around_the_apad() -> None:
    params, position, units, seed = scenario_units("pool12")
    assert params == AcousticParams() and position == (0.0, 0.0, 0.0) and seed == 1
    assert [u.address for u in units] == list(range(1, 13))
    ranges = [float(np.hypot(*u.position_m[:2])) for u in units]
    assert min(ranges) > 0.0 and max(ranges) < 40.0  # the pool is 34 m across, the aPad at its west end
    assert len({u.position_m[2] for u in units}) == 1 and units[0].position_m[2] > 0.0  # on the seabed


def test_the_acoustic_table_is_off_by_default_and_read_when_given(tmp_path: Path) -> None:
    assert load_scenario("pool12").acoustic == AcousticParams() and not AcousticParams().enabled
    text = (MISSIONS_DIR / "pool12.toml").read_text().replace('"areas/', f'"{MISSIONS_DIR}/areas/').replace(
        '"starts/', f'"{MISSIONS_DIR}/starts/')
    on = tmp_path / "pool12-acoustic.toml"
    on.write_text(text + "\n[acoustic]\nenabled = true\nsound_speed_mps = 1480\nguard_s = 0.1\nfading_m = 0\n")
    acoustic = load_scenario(on).acoustic
    assert (acoustic.enabled, acoustic.sound_speed_mps, acoustic.guard_s, acoustic.fading_m) == (True, 1480.0, 0.1, 0.0)
    on.write_text(text + "\n[acoustic]\nmax_packet_bytes = 65\n")
    with pytest.raises(ScenarioError, match=r"acoustic\.max_packet_bytes: 65 is outside \[2, 64\]"):
        load_scenario(on)
    on.write_text(text + "\n[acoustic]\nsource_level = 168\n")
    with pytest.raises(ScenarioError, match=r"acoustic\.source_level: unknown field"):
        load_scenario(on)
