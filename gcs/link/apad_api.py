"""The aPad API mission scripts use, in the spirit of the paper's Listing 1.

    loc = api.get_location(24)
    api.go_to((loc.lat, loc.lon))
    while api.goto_status(apad_id) == Progress.IN_PROGRESS:
        clock.sleep(1)
    api.docking(True, 2, 24)

Everything is keyed by aPad system id; with a single aPad the id may be omitted. Commands go
over the MAVLink command protocol (ACK, timeout, retry) and raise `CommandError` on refusal.
The planner, the scenario loop and the console's operator commands are written on this API; the
state it reads is the link's one registry (`gcs.link.registry`).
"""

from __future__ import annotations

import copy
from collections.abc import Iterator, Sequence
from contextlib import contextmanager

from apad_sitl.geofence import Geofence
from apad_sitl.vocabulary import N_SLOTS, Primitive, Progress, RoverMode
from gcs.link.command_protocol import CommandError
from gcs.link.fleet_table import MusselTable
from gcs.link.registry import VehicleView
from gcs.link.router import Link
from gcs.link.telemetry import DEG_E7, Location, MusselView, SlotView
from mavlink_dialect import MAV_CMD_APAD_DOCK, MAV_CMD_APAD_UNDOCK, mavlink
from missiontime import Clock, seconds_to_us
from mussel_sim.behaviour import sleep_order_problem
from mussel_sim.geo import LocalFrame
from mussel_sim.vocabulary import MusselCommand

__all__ = ["ApadApi", "CommandError", "GeofenceError", "Location", "MusselView", "Progress", "UnknownMussel"]


class GeofenceError(CommandError):
    """A Go To the GCS refuses to send: the target is outside the scenario's geofence."""

    def __init__(self, system_id: int, lat: float, lon: float) -> None:
        super().__init__(system_id, mavlink.MAV_CMD_DO_REPOSITION, mavlink.MAV_RESULT_DENIED,
                         f"target {lat:.7f}, {lon:.7f}; not sent", words="outside geofence")


class UnknownMussel(KeyError):
    def __str__(self) -> str:
        return f"no status heard from aMussel {self.args[0]}"


class ApadApi:
    """Listing 1's calls over one `Link`: state from its registry, commands through its command client."""

    def __init__(
        self, link: Link, clock: Clock, default_apad: int | None = None,
        geofence_deg: Sequence[tuple[float, float]] | None = None,
    ) -> None:
        """`geofence_deg`: a (lat, lon) ring; Go To targets outside it raise `GeofenceError` unsent."""
        self.link = link
        # The same test the aPad applies: a Go To it would refuse is not sent at all.
        self._fence = Geofence.of(geofence_deg, LocalFrame(*geofence_deg[0])) if geofence_deg else None
        self.clock = clock
        self.default_apad = default_apad

    @property
    def mussels(self) -> MusselTable:
        """Every aMussel heard (simulated or real), by id."""
        return self.link.registry.mussels

    # --- vehicles ---------------------------------------------------------------------------

    def apad(self, apad_id: int | None = None) -> VehicleView:
        """The view of one aPad; without an id, the only (or default) one."""
        if apad_id is None:
            apad_id = self.default_apad
        if apad_id is None:
            if len(self.link.vehicles) != 1:
                raise LookupError(f"{len(self.link.vehicles)} aPads known: pass apad_id")
            return next(iter(self.link.vehicles.values()))
        try:
            return self.link.vehicles[apad_id]
        except KeyError:
            raise LookupError(f"aPad {apad_id} has not been heard") from None

    def wait_apad(self, timeout_s: float = 10.0, apad_id: int | None = None) -> int:
        """Wait (on this API's clock) for an aPad's heartbeat and first position; return its system id."""
        want = apad_id if apad_id is not None else self.default_apad
        deadline = self.clock.time() + timeout_s
        while True:
            view = next((v for sysid, v in self.link.vehicles.items() if want is None or sysid == want), None)
            if view is not None and view.lat_deg is not None:
                return view.system_id
            if self.clock.time() > deadline:
                if view is None:
                    who = "an aPad" if want is None else f"aPad {want}"
                    raise TimeoutError(f"no heartbeat from {who} within {timeout_s:g} s")
                raise TimeoutError(f"aPad {view.system_id} sent no position within {timeout_s:g} s")
            self.clock.sleep(0.05)

    def on_clock(self, clock: Clock) -> ApadApi:
        """The same API waiting on another clock (an aPad loop's own, when several share the link)."""
        twin = copy.copy(self)
        twin.clock = clock
        return twin

    def set_telemetry_rates(
        self, rates_hz: dict[int, float], apad_id: int | None = None, retries: int = 7
    ) -> dict[int, CommandError]:
        """Ask the aPad for each message id at a rate (Hz; 0 stops it), as stock GCSs do.

        A request the aPad refuses or never answers (a lossy link: `retries` + 1 sends) is not
        fatal: that message keeps the aPad's default rate. Returns those failures by message id."""
        sysid = self.apad(apad_id).system_id
        failed: dict[int, CommandError] = {}
        for msg_id, hz in rates_hz.items():
            interval_us = seconds_to_us(1.0 / hz) if hz > 0 else -1
            try:
                self.link.commands.send_long(sysid, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, (msg_id, interval_us),
                                             retries=retries, clock=self.clock)
            except CommandError as exc:
                failed[msg_id] = exc
        return failed

    def position(self, apad_id: int | None = None) -> Location:
        view = self.apad(apad_id)
        if view.lat_deg is None or view.lon_deg is None:
            raise LookupError(f"aPad {view.system_id} has sent no position yet")
        return Location(view.lat_deg, view.lon_deg)

    def battery_v(self, apad_id: int | None = None) -> float | None:
        return self.apad(apad_id).battery_v

    def slots(self, apad_id: int | None = None) -> list[SlotView]:
        return [self.apad(apad_id).slots[s] for s in range(1, N_SLOTS + 1)]

    # --- aMussels ---------------------------------------------------------------------------

    def get_location(self, mussel_id: int) -> Location:
        """Last received position of an aMussel."""
        self.link.registry.positions_at(self.clock.now_us)
        try:
            return self.mussels[mussel_id].location
        except KeyError:
            raise UnknownMussel(mussel_id) from None

    def command_mussel(self, mussel_id: int, command: MusselCommand, apad_id: int | None = None) -> None:
        """Relay an instruction (surface / sink) to an aMussel through an aPad."""
        target = self.apad(apad_id).system_id
        self.link.send(mavlink.MAVLink_amussel_command_message(target, mussel_id, int(command)))

    def sleep_order(self, mussel_id: int, interval_s: float, awake_s: float, apad_id: int | None = None) -> None:
        """Relay a sleep order through an aPad: wake every `interval_s`, awake for `awake_s` (the
        aMussel's own seconds; interval 0: always on). ValueError for values no aMussel takes
        (`mussel_sim.behaviour.sleep_order_problem`), unsent; like `command_mussel`, no acknowledgement."""
        problem = sleep_order_problem(interval_s, awake_s)
        if problem is not None:
            raise ValueError(f"sleep order for aMussel {mussel_id}: bad {problem} ({interval_s=}, {awake_s=})")
        target = self.apad(apad_id).system_id
        self.link.send(mavlink.MAVLink_amussel_sleep_order_message(target, mussel_id, interval_s, awake_s))

    # --- primitives -------------------------------------------------------------------------

    def inside_geofence(self, latlon: tuple[float, float] | Location) -> bool:
        """Whether a Go To there would be sent (True when no geofence was given)."""
        return self._fence is None or self._fence.contains_deg(latlon[0], latlon[1])

    def go_to(
        self,
        latlon: tuple[float, float] | Location,
        speed: float = -1.0,
        radius: float = 0.0,
        apad_id: int | None = None,
    ) -> None:
        """Go To Point: speed in m/s (<= 0: the aPad's default), victory radius in m (0: default)."""
        sysid = self.apad(apad_id).system_id
        if not self.inside_geofence(latlon):
            raise GeofenceError(sysid, latlon[0], latlon[1])
        lat_e7, lon_e7 = round(latlon[0] * DEG_E7), round(latlon[1] * DEG_E7)
        with self._expecting(sysid, Primitive.GOTO, lat_e7, lon_e7):
            self.link.commands.send_int(
                sysid, mavlink.MAV_CMD_DO_REPOSITION, mavlink.MAV_FRAME_GLOBAL_INT,
                (speed, float(mavlink.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE), radius, float("nan")),
                lat_e7, lon_e7, clock=self.clock,
            )

    def hold(self, apad_id: int | None = None, timeout_s: float = 1.0, retries: int = 3) -> None:
        """Hold Position (dynamic positioning) where the aPad is now; `timeout_s`, `retries` as
        `CommandClient.send_long` (a console quitting waits little)."""
        sysid = self.apad(apad_id).system_id
        with self._expecting(sysid, Primitive.HOLD):
            self.link.commands.send_long(
                sysid, mavlink.MAV_CMD_DO_SET_MODE, (mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, RoverMode.HOLD),
                timeout_s=timeout_s, retries=retries, clock=self.clock,
            )

    def docking(self, dock: bool, slot: int, mussel_id: int = 0, apad_id: int | None = None) -> None:
        """Dock `mussel_id` into `slot` (1..4), or undock the slot (mussel_id 0: whatever is there)."""
        sysid = self.apad(apad_id).system_id
        kind, command = (Primitive.DOCK, MAV_CMD_APAD_DOCK) if dock else (Primitive.UNDOCK, MAV_CMD_APAD_UNDOCK)
        with self._expecting(sysid, kind, slot, mussel_id if dock else 0):
            self.link.commands.send_long(sysid, command, (slot, mussel_id), clock=self.clock)

    @contextmanager
    def _expecting(self, sysid: int, kind: Primitive, a: int = 0, b: int = 0) -> Iterator[None]:
        """Expect the primitive about to be commanded; a refusal puts back the one expected before
        (nothing changed on the aPad, so whoever waits on that one goes on waiting on it)."""
        before = self.link.vehicles[sysid].expected
        self.link.registry.expect(sysid, kind, a, b)
        try:
            yield
        except CommandError as exc:
            if exc.result is not None:
                self.link.registry.expect_again(sysid, before)
            raise

    def fresh_slot(self, slot: int, apad_id: int | None = None, timeout_s: float = 2.0, attempts: int = 5) -> SlotView:
        """The slot as the aPad reports it in answer to a request now (REQUEST_MESSAGE), not a report
        that may be stale because the on-change one was lost. Raises `CommandError` if it never answers."""
        view = self.apad(apad_id)
        old = view.slots[slot]
        for _ in range(attempts):
            view.slots[slot] = SlotView(slot, mussel_id=-1)  # unknown until the answer comes
            try:
                self.link.commands.send_long(view.system_id, mavlink.MAV_CMD_REQUEST_MESSAGE,
                                             (mavlink.MAVLINK_MSG_ID_DOCK_SLOT_STATUS, slot), clock=self.clock)
            except CommandError:
                continue
            deadline = self.clock.time() + timeout_s
            while view.slots[slot].mussel_id == -1 and self.clock.time() < deadline:
                self.clock.sleep(0.05)
            if view.slots[slot].mussel_id != -1:
                return view.slots[slot]
        if view.slots[slot].mussel_id == -1:
            view.slots[slot] = old
        raise CommandError(view.system_id, mavlink.MAV_CMD_REQUEST_MESSAGE, None,
                           f"no DOCK_SLOT_STATUS for slot {slot}")

    def primitive_status(self, apad_id: int | None = None) -> Progress:
        """Progress of the primitive last commanded through this API (IN_PROGRESS == 1).

        Until the aPad reports on that very primitive (a status may still be in flight from
        before the command) the answer is IN_PROGRESS, so a Listing-1 loop never exits early;
        once it has, a report about another primitive means ours was preempted: FAILED.
        """
        view = self.apad(apad_id)
        expected = view.expected
        if expected is None:
            return view.primitive.progress
        if not expected.seen:
            return Progress.IN_PROGRESS
        return view.primitive.progress if expected.matches(view.primitive) else Progress.FAILED

    def primitive_heard(self, apad_id: int | None = None) -> bool:
        """Whether the aPad has reported on the primitive last commanded through this API (True if none)."""
        expected = self.apad(apad_id).expected
        return expected is None or expected.seen

    def goto_status(self, apad_id: int | None = None) -> Progress:
        return self.primitive_status(apad_id)

    def docking_status(self, apad_id: int | None = None) -> Progress:
        return self.primitive_status(apad_id)
