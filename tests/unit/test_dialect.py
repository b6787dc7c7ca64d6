"""The dialect: generated module matches the XML today, ids sit in their private block."""

from __future__ import annotations

import importlib
from pathlib import Path

from mavlink_dialect import MAV_CMD_APAD_DOCK, MAV_CMD_APAD_UNDOCK, mavlink
from mavlink_dialect.generate import MODULE_PATH, XML_PATH, generate

OUR_MESSAGES = ["AMUSSEL_STATUS", "AMUSSEL_SENSORS", "DOCK_SLOT_STATUS", "PRIMITIVE_STATUS", "AMUSSEL_COMMAND"]


def test_committed_module_is_what_mavgen_makes_from_the_xml_now(tmp_path: Path) -> None:
    fresh = generate(XML_PATH, tmp_path / "subcultron.py")
    assert fresh.read_bytes() == MODULE_PATH.read_bytes()


def test_message_and_command_ids_are_in_the_private_block() -> None:
    ids = {name: getattr(mavlink, f"MAVLINK_MSG_ID_{name}") for name in OUR_MESSAGES}
    assert all(54000 <= i <= 54099 for i in ids.values()), ids
    assert 54000 <= MAV_CMD_APAD_DOCK <= 54099 and 54000 <= MAV_CMD_APAD_UNDOCK <= 54099


def test_no_collision_with_upstream_dialects() -> None:
    ours = {getattr(mavlink, f"MAVLINK_MSG_ID_{name}") for name in OUR_MESSAGES}
    for upstream in ("ardupilotmega", "all"):
        mod = importlib.import_module(f"pymavlink.dialects.v20.{upstream}")
        assert not ours & set(mod.mavlink_map), upstream
        assert MAV_CMD_APAD_DOCK not in mod.enums["MAV_CMD"], upstream
        assert MAV_CMD_APAD_UNDOCK not in mod.enums["MAV_CMD"], upstream


def test_common_messages_keep_their_crc_extra() -> None:
    # The dialect includes common.xml: stock tools must decode our GLOBAL_POSITION_INT etc.
    common = importlib.import_module("pymavlink.dialects.v20.common")
    for msg_id, cls in common.mavlink_map.items():
        assert mavlink.mavlink_map[msg_id].crc_extra == cls.crc_extra


def test_the_models_vocabulary_is_what_the_wire_carries() -> None:
    """Each model enum has exactly the members and values of its dialect enum, no more, no fewer."""
    from apad_sitl.vocabulary import Latch, Primitive, Progress
    from mussel_sim.vocabulary import MusselCommand, MusselState

    pairs = {
        "AMUSSEL_STATE": (MusselState, "AMUSSEL_STATE_"),
        "AMUSSEL_COMMAND_TYPE": (MusselCommand, "AMUSSEL_COMMAND_"),
        "DOCK_LATCH_STATE": (Latch, "DOCK_LATCH_STATE_"),
        "APAD_PRIMITIVE": (Primitive, "APAD_PRIMITIVE_"),
        "PRIMITIVE_PROGRESS": (Progress, "PRIMITIVE_PROGRESS_"),
    }
    for wire_name, (model, prefix) in pairs.items():
        wire = {e.name.removeprefix(prefix): value for value, e in mavlink.enums[wire_name].items()
                if not e.name.endswith("_ENUM_END")}
        assert wire == {m.name: m.value for m in model}, wire_name
