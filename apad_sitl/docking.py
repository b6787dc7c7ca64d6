"""Docking: the table of aMussel fixes the aPad has heard, and the dialect's Dock and Undock commands.

`MusselFixTable` keeps the latest AMUSSEL_STATUS of each aMussel as received (degE7, state) and turns
it into local metres only when a dock asks (most aMussels are never docked by this aPad). It
validates what it takes, once: an id in 1..MAX_MUSSEL_ID, latitude and longitude in range, a known
MusselState; anything else is dropped and counted ("invalid:AMUSSEL_STATUS:lat"). `update` takes
one message; `update_many` takes the columns of a batch decoder.

Dock (slot, aMussel id) and Undock (slot, expected aMussel id or 0) go to the primitives model;
its refusal travels in COMMAND_ACK.result_param2 and as a STATUSTEXT. `slots_changed` is a listener
of the primitive (the core's wiring): it logs every slot that changed and reports a failed dock.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from apad_sitl import primitives as prim
from apad_sitl.geofence import Geofence
from apad_sitl.host import ACCEPT, DENIED, Command, CommandRegistry, PartHost, Reply, invalid_reason, whole
from apad_sitl.primitives import REFUSAL_TEXT, MusselFix, PrimitiveState, Refusal
from apad_sitl.state import ApadState
from apad_sitl.vocabulary import N_SLOTS, Latch, Primitive, Progress
from mavlink_dialect import MAV_CMD_APAD_DOCK, MAV_CMD_APAD_UNDOCK, mavlink
from mussel_sim.geo import LocalFrame
from mussel_sim.vocabulary import MusselState

MAX_MUSSEL_ID = 0xFFFF  # AMUSSEL_STATUS.mussel_id is a uint16; 0 is no aMussel
MAX_LAT_E7 = 90 * 10**7
MAX_LON_E7 = 180 * 10**7
KNOWN_STATES = np.array([int(s) for s in MusselState])
_STATES = frozenset(KNOWN_STATES.tolist())
STATUS = "AMUSSEL_STATUS"
BatteryListener = Callable[[Iterable[tuple[int, float, int]]], None]  # (aMussel id, battery 0..1, sender) heard


class MusselFixTable(Mapping[int, MusselFix]):
    """Latest valid AMUSSEL_STATUS per aMussel id; converted to local metres lazily, only when asked."""

    def __init__(self, frame: LocalFrame, dropped: Counter[str] | None = None) -> None:
        """`dropped` counts what fails validation, by reason (the vehicle's drop counter)."""
        self._frame = frame
        self.dropped: Counter[str] = dropped if dropped is not None else Counter()
        self._raw: dict[int, tuple[int, int, int]] = {}  # id -> (lat degE7, lon degE7, state)
        self._fixes: dict[int, MusselFix] = {}

    def update(self, mussel_id: int, lat_e7: int, lon_e7: int, state: int) -> bool:
        """Take one status; False (and counted) if a field is out of range."""
        if not 1 <= mussel_id <= MAX_MUSSEL_ID:
            field = "mussel_id"
        elif not -MAX_LAT_E7 <= lat_e7 <= MAX_LAT_E7:
            field = "lat"
        elif not -MAX_LON_E7 <= lon_e7 <= MAX_LON_E7:
            field = "lon"
        elif state not in _STATES:
            field = "state"
        else:
            self._store(mussel_id, lat_e7, lon_e7, state)
            return True
        self.dropped[invalid_reason(STATUS, field)] += 1
        return False

    def update_many(
        self,
        ids: NDArray[np.integer[Any]],
        lat_e7: NDArray[np.integer[Any]],
        lon_e7: NDArray[np.integer[Any]],
        state: NDArray[np.integer[Any]],
    ) -> int:
        """Take a batch of statuses, each an integer array of shape (n,), in arrival order (a later row
        of the same aMussel wins). Rows failing validation are dropped and counted, by their first
        bad field; returns how many rows were taken. ValueError if the arrays are not (n,) integers."""
        return self.take(checked_statuses(ids, lat_e7, lon_e7, state))

    def take(self, batch: CheckedStatuses) -> int:
        """Take a batch `checked_statuses` made (one check serves every aPad that heard it)."""
        rows, drops = batch
        for reason, count in drops:
            self.dropped[reason] += count
        # A batch is the whole fleet once a second: take it in one dict update, and let every fix be
        # converted afresh when next asked (only a dock asks, for one aMussel).
        self._raw.update(rows)
        self._fixes.clear()
        return len(rows)

    def _store(self, mussel_id: int, lat_e7: int, lon_e7: int, state: int) -> None:
        raw = (lat_e7, lon_e7, state)
        if self._raw.get(mussel_id) != raw:
            self._raw[mussel_id] = raw
            self._fixes.pop(mussel_id, None)

    def __getitem__(self, mussel_id: int) -> MusselFix:
        fix = self._fixes.get(mussel_id)
        if fix is None:
            lat_e7, lon_e7, state = self._raw[mussel_id]
            x, y = self._frame.to_local(lat_e7 / 1e7, lon_e7 / 1e7)
            fix = MusselFix(float(x), float(y), docked=state == MusselState.DOCKED)
            self._fixes[mussel_id] = fix
        return fix

    def __iter__(self) -> Iterator[int]:
        return iter(self._raw)

    def __len__(self) -> int:
        return len(self._raw)


# The rows to store, (id, (lat degE7, lon degE7, state)) in arrival order, and what was dropped, by reason.
CheckedStatuses = tuple[list[tuple[int, tuple[int, int, int]]], list[tuple[str, int]]]


def checked_statuses(
    ids: NDArray[np.integer[Any]],
    lat_e7: NDArray[np.integer[Any]],
    lon_e7: NDArray[np.integer[Any]],
    state: NDArray[np.integer[Any]],
) -> CheckedStatuses:
    """`MusselFixTable.update_many`'s checks, apart from any table."""
    columns = [np.asarray(a) for a in (ids, lat_e7, lon_e7, state)]
    n = columns[0].shape[0] if columns[0].ndim == 1 else -1
    for a in columns:
        if a.shape != (n,) or not np.issubdtype(a.dtype, np.integer):
            raise ValueError("update_many takes integer arrays of one shape (n,)")
    i, la, lo, st = columns
    idl, lats, lons, states = i.tolist(), la.tolist(), lo.tolist(), st.tolist()
    # Range checks on the Python lists the table takes anyway: a fleet's batch is a few dozen rows,
    # where numpy's cost per call outweighs its speed per row.
    fine = not n or (
        min(idl) >= 1 and max(idl) <= MAX_MUSSEL_ID and min(lats) >= -MAX_LAT_E7 and max(lats) <= MAX_LAT_E7
        and min(lons) >= -MAX_LON_E7 and max(lons) <= MAX_LON_E7
        and min(states) >= 0 and max(states) < len(MusselState)  # 0..5
    )
    drops: list[tuple[str, int]] = []
    if not fine:  # the rare case: count each bad row by its first bad field, keep the rest
        with np.errstate(over="ignore"):
            checks = (
                ("mussel_id", (i >= 1) & (i <= MAX_MUSSEL_ID)),
                ("lat", (la >= -MAX_LAT_E7) & (la <= MAX_LAT_E7)),
                ("lon", (lo >= -MAX_LON_E7) & (lo <= MAX_LON_E7)),
                ("state", np.isin(st, KNOWN_STATES)),
            )
        good = np.ones(n, dtype=bool)
        for field, ok in checks:
            bad = int(np.count_nonzero(good & ~ok))
            if bad:
                drops.append((invalid_reason(STATUS, field), bad))
            good &= ok
        idl, lats, lons, states = i[good].tolist(), la[good].tolist(), lo[good].tolist(), st[good].tolist()
    return list(zip(idl, zip(lats, lons, states, strict=True), strict=True)), drops


class Docking:
    """The vehicle's docking part: feeds the aMussel table, runs Dock and Undock, reports the latches.

    `mussels` is the vehicle's table (its physics reads it too); `geofence` (None: none) is the water
    an Undock must be over; `batteries` (if given) hears each status's (aMussel id, battery, sender).
    """

    def __init__(
        self, host: PartHost, apad: ApadState, commands: CommandRegistry, mussels: MusselFixTable,
        geofence: Geofence | None, batteries: BatteryListener | None = None,
    ) -> None:
        self._host = host
        self._apad = apad
        self._geofence = geofence
        self._batteries = batteries
        self.mussels = mussels
        host.on(mavlink.MAVLINK_MSG_ID_AMUSSEL_STATUS, self._on_amussel_status)
        commands.register(MAV_CMD_APAD_DOCK, self._cmd_dock, stateful=True)
        commands.register(MAV_CMD_APAD_UNDOCK, self._cmd_undock, stateful=True)

    def _on_amussel_status(self, msg: Any) -> None:
        if self.mussels.update(msg.mussel_id, msg.lat, msg.lon, msg.state) and self._batteries is not None:
            self._batteries([(msg.mussel_id, msg.battery, msg.get_srcSystem())])

    def _slot_and_mussel(self, what: str, cmd: Command, lowest_id: int) -> tuple[int, int] | Reply:
        """param1 a slot 1..N_SLOTS, param2 an aMussel id (from `lowest_id`); a refusal if either is none."""
        slot, mussel_id = whole(cmd.params[0], 1, N_SLOTS), whole(cmd.params[1], lowest_id, MAX_MUSSEL_ID)
        if slot is None:
            return self._refuse(what, cmd, Refusal.BAD_SLOT, cmd.field(1))
        if mussel_id is None:
            return self._refuse(what, cmd, Refusal.BAD_MUSSEL_ID, cmd.field(2))
        return slot, mussel_id

    def _cmd_dock(self, cmd: Command) -> Reply:
        checked = self._slot_and_mussel("Dock", cmd, lowest_id=1)
        if isinstance(checked, Reply):
            return checked
        slot, mussel_id = checked
        apad = self._apad
        held = apad.primitive.slot_state(slot)
        if held.mussel_id == mussel_id and held.latch in (Latch.CLOSING, Latch.LATCHED) and not self._docking(
                slot, mussel_id):
            return self._redock(slot, mussel_id, held.latch)
        new, refusal = prim.dock(apad.primitive, slot, mussel_id, apad.state.x_m, apad.state.y_m, self.mussels,
                                 apad.params)
        return self._result("Dock", slot, mussel_id, new, refusal)

    def _docking(self, slot: int, mussel_id: int) -> bool:
        """Whether the Dock of this aMussel into this slot is the primitive in force (a repeat changes nothing)."""
        p = self._apad.primitive
        return p.kind == Primitive.DOCK and (p.slot, p.mussel_id) == (slot, mussel_id)

    def _redock(self, slot: int, mussel_id: int, latch: Latch) -> Reply:
        """A Dock of what the slot already holds, once the aPad has moved on to another primitive: a
        latch still closing is a Dock to follow again (its report ends it, done or failed); a latched one
        is refused, "slot occupied" (the slot holds it from before: e.g. a script run twice), so the
        Dock is never accepted with nothing to report on it."""
        apad = self._apad
        if latch == Latch.LATCHED:
            return self._result("Dock", slot, mussel_id, apad.primitive, Refusal.SLOT_OCCUPIED)
        hx, hy = prim.hold_point(apad.primitive, apad.state.x_m, apad.state.y_m)
        apad.set_primitive(replace(apad.primitive, kind=Primitive.DOCK, progress=Progress.IN_PROGRESS, target_x_m=hx,
                                   target_y_m=hy, speed_mps=0.0, radius_m=0.0, slot=slot, mussel_id=mussel_id))
        return ACCEPT

    def _cmd_undock(self, cmd: Command) -> Reply:
        checked = self._slot_and_mussel("Undock", cmd, lowest_id=0)  # 0: whatever the slot holds
        if isinstance(checked, Reply):
            return checked
        slot, mussel_id = checked
        host, apad = self._host, self._apad
        if self._geofence is not None and not self._geofence.contains(apad.state.x_m, apad.state.y_m):
            host.statustext(mavlink.MAV_SEVERITY_WARNING, f"Undock slot {slot} refused: not over water")
            host.event("geofence", what="undock", slot=slot)
            return Reply(DENIED)
        new, refusal = prim.undock(apad.primitive, slot, mussel_id, apad.state.x_m, apad.state.y_m, apad.params)
        return self._result("Undock", slot, mussel_id, new, refusal)

    def _refuse(self, what: str, cmd: Command, refusal: Refusal, field: str) -> Reply:
        """A slot or aMussel id that is none: refused like the model refuses, and counted."""
        slot, mussel_id = (_shown(p) for p in cmd.params[:2])
        self._warn(what, slot, mussel_id, refusal)
        return Reply(DENIED, int(refusal), invalid=field)

    def _result(self, what: str, slot: int, mussel_id: int, new: PrimitiveState, refusal: Refusal | None) -> Reply:
        if refusal is not None:
            self._warn(what, slot, mussel_id, refusal)
            return Reply(DENIED, int(refusal))
        self._apad.set_primitive(new)
        return ACCEPT

    def _warn(self, what: str, slot: int, mussel_id: int, refusal: Refusal) -> None:
        self._host.statustext(mavlink.MAV_SEVERITY_WARNING,
                              f"{what} slot {slot} aMussel {mussel_id}: {REFUSAL_TEXT[refusal]}")

    def slots_changed(self, old: PrimitiveState, new: PrimitiveState) -> None:
        """Log every slot that changed; a latch that reopened while closing is a failed dock."""
        host = self._host
        for i, (a, b) in enumerate(zip(old.slots, new.slots, strict=True)):
            if (a.mussel_id, a.latch, a.charging) == (b.mussel_id, b.latch, b.charging):
                continue
            slot = i + 1
            host.event("slot", slot=slot, mussel_id=b.mussel_id, latch=b.latch.name, charging=b.charging)
            if a.latch == Latch.CLOSING and b.latch == Latch.OPEN:
                text = f"Dock slot {slot} aMussel {a.mussel_id} failed: out of reach"
                host.statustext(mavlink.MAV_SEVERITY_WARNING, text)
                host.event("dock_failed", slot=slot, mussel_id=a.mussel_id, reason="out of reach")


def _shown(value: float) -> int:
    """A parameter as the refusal text shows it: the whole number, or -1 if it is none."""
    shown = whole(value, -(2**31), 2**31 - 1)
    return -1 if shown is None else shown
