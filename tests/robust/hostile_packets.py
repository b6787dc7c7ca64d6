"""Hostile MAVLink with a valid CRC: every message of our dialect, fields filled with insane values.

`HostileFrames(seed)` draws a message class (every `MAVLink_*_message` of the dialect), fills each
field by its wire type with a value chosen to hurt (NaN, +-inf, 1e38, integer extremes, enum values
just past the end, undecodable and unterminated strings, arrays of the same), or, now and then, a
plausible one (our system ids, a known command, an aMussel of the fleet, a position near home) so
messages also get past the first check and deep into the handlers. It then packs the message with a
real `Codec` of a chosen sender, so the CRC (and, optionally, the signature) is valid: the frame
reaches whatever reads it, never the CRC check.

Seeded `random.Random`, no hypothesis: a million inputs must be cheap to make, and a seed replays.
Used by tests/robust/test_fuzz_hostile_fields.py and bench/fuzz_receive.py.
"""

from __future__ import annotations

import math
import random
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mavlink_dialect import MAV_CMD_APAD_DOCK, MAV_CMD_APAD_UNDOCK, Codec, mavlink

MESSAGE_CLASSES: tuple[type[Any], ...] = tuple(
    cls for _, cls in sorted(mavlink.mavlink_map.items()) if cls.__name__.startswith("MAVLink_")
)
FLOAT32_MAX = 3.4028234663852886e38
HOSTILE_FLOATS = (math.nan, -math.nan, math.inf, -math.inf, 1e38, -1e38, FLOAT32_MAX, -FLOAT32_MAX, 1e-45, -0.0,
                  2.0**31, -(2.0**31), 2.0**63, 65536.0, 1.5, -1.0, 1e20)
HOSTILE_DOUBLES = (*HOSTILE_FLOATS, 1e308, -1e308, 5e-324)
INT_RANGES = {"uint8_t": (0, 2**8 - 1), "int8_t": (-(2**7), 2**7 - 1), "uint16_t": (0, 2**16 - 1),
              "int16_t": (-(2**15), 2**15 - 1), "uint32_t": (0, 2**32 - 1), "int32_t": (-(2**31), 2**31 - 1),
              "uint64_t": (0, 2**64 - 1), "int64_t": (-(2**63), 2**63 - 1)}
HOSTILE_STRINGS = (b"", b"\xff\xfe\x80", b"\x00SPEED_MAX", b"SPEED_MAX\x00junk", b"\xc3\x28" * 8, b"%s%n{0}\n\r",
                   b"A" * 64, bytes(range(1, 32)))
PARAM_NAMES = (b"SPEED_MAX", b"FS_GCS_ENABLE", b"FS_GCS_TIMEOUT", b"SYSID_THISMAV", b"WP_RADIUS", b"NOPE")
HOME_E7 = (439_400_000, 154_398_381)  # pool12's home, degE7
FOCUS_SHARE = 0.5  # of the messages drawn, those somebody here reads; the rest from the whole dialect


def _read_here() -> tuple[type[Any], ...]:
    """The messages the GCS, the SITL aPad or the fleet act on: drawn more often, to reach every check."""
    from apad_sitl.endpoint import SitlVehicle
    from apad_sitl.params import ApadParams
    from gcs.link.telemetry import _READERS
    from mavlink_dialect import memory_pair

    with SitlVehicle(memory_pair()[0], ApadParams(), 0.0, 0.0) as vehicle:
        # AMUSSEL_COMMAND: the fleet's; APAD_MODEM_SERIAL: an aPad with a modem of its own, and the GCS's port to it
        ids = set(vehicle._handlers) | set(_READERS) | {mavlink.MAVLINK_MSG_ID_AMUSSEL_COMMAND,
                                                         mavlink.MAVLINK_MSG_ID_APAD_MODEM_SERIAL}
    return tuple(mavlink.mavlink_map[i] for i in sorted(ids))


READ_HERE = _read_here()


def _enum_values(name: str) -> tuple[int, ...]:
    """The known values of enum `name`, and the first ones past both ends (unknown on purpose)."""
    known = sorted(mavlink.enums.get(name, {}))
    if not known:
        return ()
    return (*known, known[-1] + 1, known[0] - 1, 200, 255)


@dataclass
class Hints:
    """Plausible values, so a share of messages is accepted and reaches the handlers' insides."""

    system_ids: tuple[int, ...] = (1, 250, 251, 0)
    mussel_ids: tuple[int, ...] = tuple(range(1, 13))
    commands: tuple[int, ...] = (
        mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, mavlink.MAV_CMD_DO_CHANGE_SPEED,
        mavlink.MAV_CMD_DO_REPOSITION, mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL,
        mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, mavlink.MAV_CMD_GET_HOME_POSITION, MAV_CMD_APAD_DOCK,
        MAV_CMD_APAD_UNDOCK, mavlink.MAV_CMD_NAV_TAKEOFF,
    )
    home_e7: tuple[int, int] = HOME_E7


@dataclass
class HostileFrames:
    """A seeded source of hostile messages and of their frames, packed by one of `senders`."""

    seed: int
    senders: Sequence[Codec]
    hints: Hints = field(default_factory=Hints)
    hostile_share: float = 0.5  # chance that a field gets a hostile value rather than a plausible one
    classes: Sequence[type[Any]] = MESSAGE_CLASSES

    def __post_init__(self) -> None:
        self.rng = random.Random(self.seed)
        self.drawn: dict[str, int] = {}  # message name -> how many were made
        self._focus = [c for c in READ_HERE if c in self.classes]

    def frame(self) -> bytes:
        """One frame: a hostile message, packed (valid CRC) by a sender drawn at random."""
        msg = self.message()
        return self.rng.choice(self.senders).encode(msg)

    def message(self) -> Any:
        focus = self._focus
        cls = self.rng.choice(focus if focus and self.rng.random() < FOCUS_SHARE else self.classes)
        lengths = dict(zip(cls.ordered_fieldnames, cls.array_lengths, strict=True))
        enums = getattr(cls, "fieldenums_by_name", {})
        args = [self._value(name, ftype, lengths[name], enums.get(name)) for name, ftype in
                zip(cls.fieldnames, cls.fieldtypes, strict=True)]
        self.drawn[cls.msgname] = self.drawn.get(cls.msgname, 0) + 1
        return cls(*args)

    # --- values --------------------------------------------------------------------------------

    def _value(self, name: str, ftype: str, length: int, enum: str | None) -> Any:
        r = self.rng
        if ftype == "char":
            return self._chars(name, max(length, 1))
        if length:
            if r.random() < 0.5:  # the same value throughout, or each element drawn on its own
                return [self._scalar(name, ftype, enum)] * length
            return [self._scalar(name, ftype, enum) for _ in range(length)]
        return self._scalar(name, ftype, enum)

    def _chars(self, name: str, length: int) -> bytes:
        r = self.rng
        if r.random() < self.hostile_share:
            pick = r.choice(HOSTILE_STRINGS) if r.random() < 0.7 else r.randbytes(r.randint(0, length))
        elif name == "param_id":
            pick = r.choice(PARAM_NAMES)
        else:
            pick = b"hello"
        return pick[:length]

    def _scalar(self, name: str, ftype: str, enum: str | None) -> Any:
        r = self.rng
        hostile = r.random() < self.hostile_share
        if ftype in ("float", "double"):
            if hostile:
                return r.choice(HOSTILE_FLOATS if ftype == "float" else HOSTILE_DOUBLES)
            return self._plausible_float(name)
        lo, hi = INT_RANGES[ftype]
        if hostile:
            choice = r.random()
            if choice < 0.5:
                return r.choice((lo, hi, lo + 1, hi - 1, 0))
            if choice < 0.7 and enum:
                return min(hi, max(lo, r.choice(_enum_values(enum))))
            return r.randint(lo, hi)
        return min(hi, max(lo, self._plausible_int(name, enum)))

    def _plausible_float(self, name: str) -> float:
        r = self.rng
        if name in ("param5", "param6"):  # a command's lat/lon in degrees (DO_REPOSITION)
            home = self.hints.home_e7[name == "param6"] / 1e7
            return home + r.uniform(-0.001, 0.001)
        if name.startswith("param"):
            return float(r.choice((0, 1, 2, 4, 15, -1, 24, r.choice(self.hints.mussel_ids))))
        if name == "battery":
            return r.random()
        return r.choice((0.0, 1.0, r.uniform(0.0, 100.0)))

    def _plausible_int(self, name: str, enum: str | None) -> int:
        r, h = self.rng, self.hints
        if name == "target_system":
            return r.choice(h.system_ids)
        if name == "target_component":
            return r.choice((0, 1, 190))
        if name == "command":
            return r.choice(h.commands)
        if name == "mussel_id":
            return r.choice(h.mussel_ids)
        if name in ("lat", "latitude", "target_lat", "x"):
            return h.home_e7[0] + r.randint(-5000, 5000)
        if name in ("lon", "longitude", "target_lon", "y"):
            return h.home_e7[1] + r.randint(-5000, 5000)
        if name == "slot":
            return r.randint(0, 5)
        if name == "param_index":
            return r.randint(-1, 16)
        if enum:
            known = _enum_values(enum)
            return r.choice(known[:-4] or known)
        return r.choice((0, 1, 2, 3))


def senders(*ids: tuple[int, int]) -> list[Codec]:
    """A `Codec` per (system, component): who the frames claim to be from."""
    return [Codec(s, c) for s, c in ids]


# ------------------------------------------------------------------ both receive paths, wired as a mission

GCS_SENDERS = ((1, 1), (1, 190), (251, 25), (250, 190), (7, 1), (0, 0), (255, 190))  # the aPad, spoofs, strangers
STRANGERS = ((7, 1), (0, 0), (255, 190), (42, 1))  # systems no mission expects
# What another GCS may legitimately tell the aPad (any GCS may command a MAVLink vehicle; signing is
# what keeps strangers out): left out where a test asks that the mission is not disturbed.
GCS_ORDERS = frozenset({"COMMAND_LONG", "COMMAND_INT", "SET_MODE", "PARAM_SET"})


class FuzzWorld:
    """A mission's world (`gcs.mission.world.headless_world`: the fleet as the link's local party, the
    SITL aPad on an in-memory pair) with a door into each receive path: `to_gcs` lands frames in the
    GCS link's transport as if the aPad sent them, `to_apad` in the aPad's as if a GCS did."""

    def __init__(self, seed: int, scenario: str = "pool12", senders_ids: Sequence[tuple[int, int]] = GCS_SENDERS,
                 hostile_share: float = 0.5, classes: Sequence[type[Any]] = MESSAGE_CLASSES) -> None:
        from gcs.mission.world import headless_world
        from gcs.scenario.reader import load_scenario

        self.world = headless_world(load_scenario(scenario))
        self.world.clock.sleep(1.0)  # heartbeats exchanged: the aPad is a known vehicle
        vehicle = self.world.vehicle
        assert vehicle is not None
        self.vehicle = vehicle
        self.to_gcs = vehicle.transport
        self.to_apad = self.world.link._pollers[0].transport
        self.frames = HostileFrames(seed, senders(*senders_ids), hostile_share=hostile_share, classes=classes)
        self.fed = {"gcs": 0, "sitl": 0}

    def feed(self, target: str, frame: bytes) -> None:
        """One frame into one receive path, read at once (the scheduler's drain polls every receiver)."""
        (self.to_gcs if target == "gcs" else self.to_apad).send(frame)
        self.world.clock.scheduler.drain()
        self.fed[target] += 1

    def advance(self, seconds: float) -> None:
        """Let mission time pass: the fleet steps and the aPad moves on whatever they were told."""
        self.world.clock.sleep(seconds)

    def drops(self) -> dict[str, Counter[str]]:
        w = self.world
        return {"gcs": w.link.dropped, "fleet": w.fleet.dropped, "sitl": self.vehicle.dropped}

    def handler_errors(self) -> dict[str, int]:
        """What the catch-alls caught: each a bug that validation should have stopped."""
        return {f"{side}:{k}": n for side, c in self.drops().items() for k, n in c.items() if "handler_error" in k}

    def impossible(self) -> list[str]:
        """Whatever the GCS, the fleet or the aPad now believes that no valid message could have said."""
        w, out = self.world, []
        expected = {a.system_id for a in w.scenario.apads}
        if set(w.link.vehicles) - expected:
            out.append(f"vehicles {sorted(w.link.vehicles)} beyond the expected {sorted(expected)}")
        for view in w.link.vehicles.values():
            if view.lat_deg is not None and not (abs(view.lat_deg) <= 90 and abs(view.lon_deg or 0.0) <= 180):
                out.append(f"aPad {view.system_id} at {view.lat_deg}, {view.lon_deg}")
            if not (math.isfinite(view.heading_deg) and math.isfinite(view.primitive.distance_to_go_m)):
                out.append(f"aPad {view.system_id}: heading or distance not finite")
            if sorted(view.slots) != [1, 2, 3, 4] or any(s.slot != k for k, s in view.slots.items()):
                out.append(f"aPad {view.system_id} slots {sorted(view.slots)}")
        t = w.link.registry.mussels
        simulated = set(int(i) for i in w.fleet.state.ids)
        for k, mussel_id in enumerate(int(i) for i in t.ids):
            if not 1 <= mussel_id <= 0xFFFF or (bool(t.simulated[k]) and mussel_id not in simulated):
                out.append(f"aMussel {mussel_id} in the GCS's table (simulated={bool(t.simulated[k])})")
        if not (np.all(np.abs(t.lat_e7) <= 90 * 10**7) and np.all(np.abs(t.lon_e7) <= 180 * 10**7)):
            out.append("an aMussel position out of range in the GCS's table")
        if not (np.all(np.isfinite(t.battery_frac)) and np.all((t.battery_frac >= 0) & (t.battery_frac <= 1))):
            out.append("an aMussel battery out of range in the GCS's table")
        if not (np.all(np.isfinite(t.depth_m)) and np.all(t.state < 6)):
            out.append("an aMussel depth or state out of range in the GCS's table")
        fleet = w.fleet
        if set(fleet.apads.deg) - expected:
            out.append(f"the fleet believes in aPads {sorted(fleet.apads.deg)}")
        for mussel_id, (apad, slot) in fleet.orders.docked_at.items():
            if apad not in expected or not 1 <= slot <= 4:
                out.append(f"the fleet docked aMussel {mussel_id} on aPad {apad} slot {slot}")
        if not (np.all(np.isfinite(fleet.state.x_m)) and np.all(np.isfinite(fleet.state.battery_frac))):
            out.append("the fleet's model holds a non-finite position or battery")
        for mussel_id in self.vehicle.mussels:
            fix = self.vehicle.mussels[mussel_id]
            if not (1 <= mussel_id <= 0xFFFF and math.isfinite(fix.x_m) and math.isfinite(fix.y_m)):
                out.append(f"the aPad's fix of aMussel {mussel_id}: {fix}")
        state = self.vehicle.state
        if not all(math.isfinite(v) for v in (state.x_m, state.y_m, state.heading_rad, state.battery_v)):
            out.append(f"the aPad's own state is not finite: {state}")
        return out

    def close(self) -> None:
        self.world.close()
