"""`vil gcs --sitl --speed 50`, killed, then `--resume`: the watched simulation goes on at x50, not
x1 (issue 23): the console's run folder keeps the speed it was started with."""

from __future__ import annotations

import json
from pathlib import Path

from gcs.cli.console import saved_speed
from gcs.records.run_folder import RunFolder


def test_a_resumed_console_takes_the_speed_its_run_was_started_with(tmp_path: Path) -> None:
    folder = RunFolder(tmp_path)
    for record, expected in (({"speed": 50.0}, 50.0), ({"speed": 50}, 50.0), ({"speed": None}, None),
                             ({"epoch_us": 1}, None), ({"speed": 1e9}, None), ({"speed": True}, None),
                             ({"speed": "50"}, None)):
        folder.console.write_text(json.dumps(record))
        assert saved_speed(folder) == expected, record
    folder.console.write_text("not json")
    assert saved_speed(folder) is None
    folder.console.unlink()
    assert saved_speed(folder) is None
