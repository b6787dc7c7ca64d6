"""The dialect: generated module and stub match the XML today, ids sit in their private block."""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

from mavlink_dialect import MAV_CMD_APAD_DOCK, MAV_CMD_APAD_UNDOCK, mavlink
from mavlink_dialect.generate import BASE_STUB_PATH, MODULE_PATH, STUB_PATH, XML_PATH, generate

OUR_MESSAGES = ["AMUSSEL_STATUS", "AMUSSEL_SENSORS", "DOCK_SLOT_STATUS", "PRIMITIVE_STATUS", "AMUSSEL_COMMAND"]


def test_committed_module_and_stub_are_what_generate_makes_from_the_xml_now(tmp_path: Path) -> None:
    fresh = generate(XML_PATH, tmp_path / "subcultron.py")
    assert fresh.read_bytes() == MODULE_PATH.read_bytes()
    assert fresh.with_suffix(".pyi").read_bytes() == STUB_PATH.read_bytes()


def _stub_top_level(stub: Path = STUB_PATH) -> dict[str, ast.stmt]:
    """The names a stub gives its module, with those it re-exports from the stub-only base module."""
    tree = ast.parse(stub.read_text(encoding="utf-8"))
    names: dict[str, ast.stmt] = {}
    for node in tree.body:
        if isinstance(node, ast.ClassDef):
            if not any(isinstance(d, ast.Name) and d.id == "type_check_only" for d in node.decorator_list):
                names[node.name] = node  # (a type_check_only class exists in the stub only)
        elif isinstance(node, ast.AnnAssign | ast.Assign):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            names.update((t.id, node) for t in targets if isinstance(t, ast.Name))
        elif isinstance(node, ast.ImportFrom) and node.module == f"mavlink_dialect.{BASE_STUB_PATH.stem}":
            base = _stub_top_level(BASE_STUB_PATH)
            for alias in node.names:  # in a stub, `*` re-exports the public names, `x as x` the name x
                if alias.name == "*":
                    names.update((n, s) for n, s in base.items() if not n.startswith("_"))
                elif alias.asname == alias.name:
                    names[alias.name] = base[alias.name]
    return names


def test_the_stub_declares_what_the_module_defines() -> None:
    """Names both ways, and every message class with its fields in constructor order."""
    stub = _stub_top_level()
    assert [name for name in stub if not hasattr(mavlink, name)] == []
    constants = [n for n, v in vars(mavlink).items() if isinstance(v, int) and not n.startswith("_")]
    assert [n for n in constants if n not in stub] == []
    for cls in mavlink.mavlink_map.values():
        node = stub[cls.__name__]
        assert isinstance(node, ast.ClassDef)
        fields = [s.target.id for s in node.body if isinstance(s, ast.AnnAssign) and isinstance(s.target, ast.Name)]
        init = next(s for s in node.body if isinstance(s, ast.FunctionDef) and s.name == "__init__")
        assert fields == cls.fieldnames, cls.__name__
        assert [a.arg for a in init.args.args[1:]] == cls.fieldnames, cls.__name__


def test_the_stub_field_types_are_what_messages_hold() -> None:
    """char[N] goes in as bytes and is read as str; an array is a list when decoded but keeps what it
    was built with (here the tuple default of an extension): hence `Sequence` in the stub."""
    sender = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    param = mavlink.MAVLink_param_value_message(b"DEPTH_MAX", 1.5, mavlink.MAV_PARAM_TYPE_REAL32, 1, 0)
    quat = mavlink.MAVLink_attitude_quaternion_message(0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    assert param.param_id == "DEPTH_MAX" and isinstance(quat.repr_offset_q, tuple)
    decoded = mavlink.MAVLink(None).parse_buffer(param.pack(sender) + quat.pack(sender)) or []
    assert [m.get_type() for m in decoded] == ["PARAM_VALUE", "ATTITUDE_QUATERNION"]
    param_back, quat_back = decoded
    assert isinstance(param_back, mavlink.MAVLink_param_value_message) and param_back.param_id == "DEPTH_MAX"
    assert isinstance(quat_back, mavlink.MAVLink_attitude_quaternion_message)
    assert quat_back.repr_offset_q == [0.0, 0.0, 0.0, 0.0]


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
    # The batch validators (gcs.link.fleet_table, apad_sitl.docking) test a state by its range.
    assert [s.value for s in MusselState] == list(range(len(MusselState)))
