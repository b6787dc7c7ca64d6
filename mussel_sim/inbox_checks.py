"""What the fleet may act on: the first field of an incoming message it must refuse, by name.

`FleetRunner.handle` (mussel_sim/comms.py) asks `invalid_field` before acting and counts a refusal by
its reason ("invalid:DOCK_SLOT_STATUS:slot"): an aPad we expect, latitude and longitude in range, a
slot 1..N_SLOTS, a known latch and command, one of our ids, a sleep order an aMussel takes.
"""

from __future__ import annotations

from collections.abc import Collection
from typing import Any

from mavlink_dialect import mavlink
from mussel_sim.behaviour import sleep_order_problem
from mussel_sim.startconfig import MAX_MUSSEL_ID
from mussel_sim.vocabulary import MusselCommand

LATCHES = frozenset(mavlink.enums["DOCK_LATCH_STATE"]) - {max(mavlink.enums["DOCK_LATCH_STATE"])}  # minus _ENUM_END
COMMANDS = frozenset(int(c) for c in MusselCommand)
N_SLOTS = 4  # an aPad's docking slots (apad_sitl.vocabulary.N_SLOTS; the fleet does not import the aPad)
MAX_LAT_E7, MAX_LON_E7 = 90 * 10**7, 180 * 10**7


# What the fleet acts on (`FleetRunner.handle`; everything else it ignores): a router need give it nothing more.
HEARD_MESSAGES = frozenset({
    mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, mavlink.MAVLINK_MSG_ID_DOCK_SLOT_STATUS,
    mavlink.MAVLINK_MSG_ID_AMUSSEL_COMMAND, mavlink.MAVLINK_MSG_ID_AMUSSEL_SLEEP_ORDER,
    mavlink.MAVLINK_MSG_ID_AMUSSEL_STATUS,
})


def invalid_field(msg: mavlink.MAVLink_message, src: int, apads: Collection[int] | None,
                  commanders: Collection[int] | None, ids: Collection[int]) -> str | None:
    """The first field of `msg` from system `src` that the fleet may not act on, or None. `apads`: the
    systems whose positions and slots are an aPad's, `commanders`: whose commands are obeyed (None: any);
    `ids`: the fleet's aMussels."""
    m: Any = msg
    if isinstance(msg, mavlink.MAVLink_global_position_int_message | mavlink.MAVLink_dock_slot_status_message):
        if apads is not None and src not in apads:
            return "source"
        if isinstance(msg, mavlink.MAVLink_global_position_int_message):
            return None if -MAX_LAT_E7 <= m.lat <= MAX_LAT_E7 and -MAX_LON_E7 <= m.lon <= MAX_LON_E7 else "lat_lon"
        if not 1 <= m.slot <= N_SLOTS:
            return "slot"
        return None if m.latch in LATCHES else "latch"
    if isinstance(msg, mavlink.MAVLink_amussel_command_message | mavlink.MAVLink_amussel_sleep_order_message):
        if commanders is not None and src not in commanders:
            return "source"
        if apads is not None and m.target_system not in apads:
            return "target"  # relayed through an aPad, or not at all
        if isinstance(msg, mavlink.MAVLink_amussel_command_message) and m.command not in COMMANDS:
            return "command"
        if m.mussel_id not in ids:
            return "mussel_id"
        return sleep_order_problem(m.interval, m.awake) if isinstance(
            msg, mavlink.MAVLink_amussel_sleep_order_message) else None
    if isinstance(msg, mavlink.MAVLink_amussel_status_message) and msg.simulated == 0:
        return None if 1 <= m.mussel_id <= MAX_MUSSEL_ID else "mussel_id"
    return None
