"""The one state the GCS holds about the swarm: a view per aPad system id and the aMussel table.

The router feeds it typed, validated records (`gcs.link.telemetry`); the aPad API, the mission
loop, the console and replay read it. Nothing else keeps a second copy of what was heard.
"""

from __future__ import annotations

from collections.abc import Callable, Collection
from dataclasses import dataclass, field

from apad_sitl.vocabulary import N_SLOTS, Latch, Primitive
from gcs.link.fleet_table import MusselTable
from gcs.link.telemetry import (
    DEG_E7,
    GCS_SYSTEM_ID,
    Battery,
    Charging,
    GoToSent,
    Heartbeat,
    Home,
    MusselView,
    ParamValue,
    Position,
    PrimitiveView,
    Record,
    SlotView,
    StatusText,
)
from mussel_sim.geo import distance_m

STATUSTEXT_KEPT = 50
# The aPad's own clock (PRIMITIVE_STATUS.time_us) going back more than this is a restart.
RESTART_SLACK_US = 2_000_000
SEQ_REORDER = 128  # a sequence step back (or a jump of more than half the 8-bit range) is no loss


@dataclass
class Expectation:
    """The primitive last commanded: its kind and key (target degE7, or slot and aMussel)."""

    kind: Primitive
    a: int
    b: int
    seen: bool = False  # the aPad has reported on this very primitive

    def matches(self, status: PrimitiveView) -> bool:
        if status.primitive != self.kind:
            return False
        if self.kind == Primitive.GOTO:
            return (status.target_lat_e7, status.target_lon_e7) == (self.a, self.b)
        if self.kind == Primitive.DOCK:
            return (status.slot, status.mussel_id) == (self.a, self.b)
        if self.kind == Primitive.UNDOCK:
            return status.slot == self.a
        return True


@dataclass
class VehicleView:
    """Everything the GCS knows about one aPad, from its own telemetry and our commands to it."""

    system_id: int
    last_heartbeat_us: int = 0
    custom_mode: int = 0
    armed: bool = False
    lat_deg: float | None = None
    lon_deg: float | None = None
    heading_deg: float = 0.0
    battery_v: float | None = None
    battery_pct: int = -1
    charging: bool = False  # at its home charger (BATTERY_STATUS.charge_state)
    home: tuple[float, float] | None = None
    primitive: PrimitiveView = field(default_factory=PrimitiveView)
    slots: dict[int, SlotView] = field(default_factory=lambda: {s: SlotView(s) for s in range(1, N_SLOTS + 1)})
    params: dict[str, float] = field(default_factory=dict)
    statustext: list[str] = field(default_factory=list)
    expected: Expectation | None = None
    # The paper's movement cost as seen on the link: aPad-to-setpoint distance per new Go To target.
    goto_cost_m: float = 0.0
    last_goto_e7: tuple[int, int] | None = None
    # Link health: frames taken from it and frames missing from its MAVLink sequence (`count_frame`).
    frames: int = 0
    frames_lost: int = 0
    # Restarts seen (its own clock went back): how many, when (our clock), what its slots held before.
    boot_us: int = -1
    restarts: int = 0
    restarted_us: int = 0
    held_before_restart: tuple[int, ...] = ()
    held_at_last_status: tuple[int, ...] = ()  # what its slots held at its last PRIMITIVE_STATUS

    def held(self) -> tuple[int, ...]:
        """The aMussels its slots hold (latched, closing or releasing)."""
        return tuple(s.mussel_id for s in self.slots.values() if s.mussel_id and s.latch != Latch.OPEN)

    def free_slots(self) -> list[int]:
        return [s.slot for s in self.slots.values() if s.free]


class VehicleRegistry:
    """One `VehicleView` per aPad system id (created by its first heartbeat) and one `MusselTable`."""

    def __init__(self, gcs_system_id: int = GCS_SYSTEM_ID, apad_ids: Collection[int] | None = None,
                 ideal: bool = False) -> None:
        """`gcs_system_id`: our own system; only its Go Tos count towards the movement cost.
        `apad_ids`: the aPads expected (only their heartbeats make vehicles); None: any vehicle.
        `ideal`: over the event platform's ideal link, which loses nobody and carries no heartbeats."""
        self.gcs_system_id = gcs_system_id
        self.ideal = ideal
        self.apad_ids = None if apad_ids is None else frozenset(apad_ids)
        self.vehicles: dict[int, VehicleView] = {}
        self.mussels = MusselTable()
        # When (our clock) each aMussel reported alone, as real agents do; the simulated fleet's
        # batches arrive every second and are not tracked here.
        self.mussel_heard_us: dict[int, int] = {}
        # When (our clock) an aPad last said a slot let go of each aMussel: charged till then, not since.
        self.released_us: dict[int, int] = {}
        self.fleet_heard_us = -1  # when (our clock) the fleet last spoke (a status, its node's heartbeat); -1: never
        self._seq: dict[tuple[int, int], int] = {}  # (system, component) -> the last sequence number taken
        self.version = 0  # bumped on every change a screen could show
        # Bumped on every change a wait could read: all of `version`'s but a battery's that crosses no watched
        # threshold (`watch_battery`); the event platform's waits look at this news (missiontime.event_clock).
        self.news = 0
        # Per aPad, counters that move with every change of what a wait reads of it (`marks`): `changed` all
        # but where it is, `moved` where it is and how far its Go To has gone. Cheap to compare, so a wait
        # builds what it reads only when one moved (`gcs.loop.fleet_knowledge.FleetKnowledge.news`).
        self.changed: dict[int, int] = {}
        self.moved: dict[int, int] = {}
        self.restores = 0
        # The event platform's ideal link: called with the time before the aMussels' positions are read.
        self.refresh_positions: Callable[[int], None] | None = None
        self._battery_watch: dict[int, dict[str, Callable[[float], bool]]] = {}

    def positions_at(self, now_us: int) -> None:
        """The aMussels' positions are about to be read at `now_us`: brought to what the GCS knows then."""
        if self.refresh_positions is not None:
            self.refresh_positions(now_us)

    def watch_battery(self, system_id: int, what: str, holds: Callable[[float], bool]) -> None:
        """A wait reads whether `holds(battery_v)` of aPad `system_id` (`what`: the mission's end, a charge
        done; watched once, whoever asks again): a report that changes it is news; one that only moves the
        volts between such thresholds is not."""
        self._battery_watch.setdefault(system_id, {})[what] = holds
        self._changed(system_id)

    def battery_news(self, system_id: int, battery_v: float | None) -> tuple[bool, ...] | None:
        """What a wait can read of aPad `system_id`'s battery: each watched threshold, held or not."""
        if battery_v is None:
            return None
        return tuple(holds(battery_v) for holds in self._battery_watch.get(system_id, {}).values())

    def silent_us(self, view: VehicleView, now_us: int) -> int:
        """How long the aPad of `view` has been silent: since its last heartbeat; 0 over the ideal link,
        which needs none to know the aPad is there (ns-3's ideal protocol: state without signalling)."""
        return 0 if self.ideal else now_us - view.last_heartbeat_us

    def lapses_us(self, view: VehicleView, silent_us: int) -> int | None:
        """When the aPad of `view`, heard now, would first have been silent `silent_us`; None: never (ideal)."""
        return None if self.ideal else view.last_heartbeat_us + silent_us

    def believes(self, system_id: int, record: Record) -> bool:
        """Whether a record that came over a transport from `system_id` may be folded in: an aMussel's
        status from anyone; anything else from an expected aPad (or, expecting none in particular, a
        heartbeat from anyone and telemetry from a vehicle heard)."""
        if isinstance(record, MusselView | GoToSent):
            return True
        if self.apad_ids is not None:
            return system_id in self.apad_ids
        return isinstance(record, Heartbeat) or system_id in self.vehicles

    def apply(self, system_id: int, record: Record, now_us: int) -> str | None:
        """Fold one record from `system_id` into the state; a reason if it was refused."""
        if isinstance(record, MusselView):
            refused = self.mussels.update(record)
            if refused is None:
                self.mussel_heard_us[record.mussel_id] = self.fleet_heard_us = now_us
                self.version += 1
                self.news += 1
            return refused
        if isinstance(record, GoToSent):
            if system_id == self.gcs_system_id:  # another GCS's (or a forged) Go To is not our cost
                self._goto_sent(record)
            return None
        if isinstance(record, Heartbeat):
            view = self.vehicles.get(system_id)
            if view is None:
                view = self.vehicles[system_id] = VehicleView(system_id)
            view.last_heartbeat_us = now_us
            view.custom_mode, view.armed = record.custom_mode, record.armed
            self.version += 1
            self.news += 1
            self._changed(system_id)
            return None
        view = self.vehicles.get(system_id)
        if view is None:
            return None  # not (yet) a vehicle: its heartbeat makes it one
        still = False  # a battery report that crosses no watched threshold: no news at all
        moves_only = False  # news only to a wait that reads the moves (`marks`)
        match record:
            case Position():
                view.lat_deg, view.lon_deg = record.lat_deg, record.lon_deg
                if record.heading_deg is not None:
                    view.heading_deg = record.heading_deg
                moves_only = True
            case PrimitiveView():
                self._check_boot(view, record.time_us, now_us)
                expected = view.expected
                moves_only = (primitive_news(view.primitive, False) == primitive_news(record, False)
                              and (expected is None or expected.seen or not expected.matches(record)))
                view.primitive = record
                if view.expected is not None and view.expected.matches(record):
                    view.expected.seen = True
            case SlotView():
                held = view.slots.get(record.slot)
                if held is not None and held.latch == Latch.LATCHED and held.mussel_id and (
                        record.latch != Latch.LATCHED or record.mussel_id != held.mussel_id):
                    self.released_us[held.mussel_id] = now_us  # it charged until now (`gcs.belief.foresight`)
                view.slots[record.slot] = record
            case Battery():
                before = view.battery_v
                if record.voltage_v is not None:
                    view.battery_v = record.voltage_v
                view.battery_pct = record.remaining_pct
                still = self.battery_news(system_id, before) == self.battery_news(system_id, view.battery_v)
            case Charging():
                view.charging = record.charging
            case Home():
                view.home = (record.lat_deg, record.lon_deg)
            case ParamValue():
                view.params[record.name] = record.value
            case StatusText():
                view.statustext.append(record.text)
                del view.statustext[:-STATUSTEXT_KEPT]
        self.version += 1
        self.news += 0 if still else 1
        if isinstance(record, Position | PrimitiveView):
            self.moved[system_id] = self.moved.get(system_id, 0) + 1
        if not (still or moves_only):
            self._changed(system_id)
        return None

    def _changed(self, system_id: int) -> None:
        self.changed[system_id] = self.changed.get(system_id, 0) + 1

    def marks(self, system_id: int, moves: bool) -> tuple[int, int]:
        """Counters that move whenever what a wait reads of aPad `system_id` may have changed (`moves`: where it
        is and how far its Go To has gone, too): unchanged, it has not."""
        return self.changed.get(system_id, 0), self.moved.get(system_id, 0) if moves else 0

    def count_frame(self, system_id: int, component_id: int, seq: int) -> None:
        """A frame taken from a transport: count it, and the frames its sequence number says were lost
        on the way since the last one of that (system, component), against the vehicle it came from."""
        view = self.vehicles.get(system_id)
        if view is None:
            return
        key = (system_id, component_id)
        last = self._seq.get(key)
        self._seq[key] = seq
        view.frames += 1
        if last is not None:
            gap = (seq - last - 1) % 256
            if gap < SEQ_REORDER:
                view.frames_lost += gap

    def _check_boot(self, view: VehicleView, boot_us: int, now_us: int) -> None:
        """The aPad's own clock went back: it restarted. Its slots it reports from now on are what it
        knows after the restart; what they held before is kept for the operator to read."""
        if 0 <= boot_us + RESTART_SLACK_US < view.boot_us:
            view.restarts += 1
            view.restarted_us = now_us
            view.held_before_restart = view.held_at_last_status
        view.boot_us = boot_us
        view.held_at_last_status = view.held()

    def __getstate__(self) -> dict[str, object]:
        """A checkpoint keeps what was heard, not the live world's hooks (the battery thresholds its waits read,
        the ideal link's positions): the world that restores makes its own (`restore` takes only the data)."""
        state = self.__dict__.copy()
        state["_battery_watch"], state["refresh_positions"] = {}, None
        return state

    def restore(self, saved: VehicleRegistry) -> None:
        """Take what a saved registry knew (a mission resumed from its checkpoint), in place: whoever
        holds this registry, its vehicle dict or its aMussel table keeps them."""
        self.vehicles.clear()
        self.vehicles.update(saved.vehicles)
        self.mussels.load(saved.mussels)
        for mine, theirs in ((self.mussel_heard_us, saved.mussel_heard_us), (self.released_us, saved.released_us)):
            mine.clear()
            mine.update(theirs)
        self.fleet_heard_us = saved.fleet_heard_us
        self.version += 1
        self.news += 1
        self.restores += 1

    def expect(self, system_id: int, kind: Primitive, a: int = 0, b: int = 0) -> None:
        """We are about to command `kind` on this aPad: its reports count once they are about it."""
        self.expect_again(system_id, Expectation(kind, a, b))

    def expect_again(self, system_id: int, expected: Expectation | None) -> None:
        """Put `expected` back as what we last commanded (a refused command leaves the one before)."""
        self.vehicles[system_id].expected = expected
        self._changed(system_id)

    def _goto_sent(self, goto: GoToSent) -> None:
        """Count the paper's cost once per new target (a retransmission carries the same one)."""
        view = self.vehicles.get(goto.target_system)
        target = (goto.lat_e7, goto.lon_e7)
        if view is None or view.lat_deg is None or view.lon_deg is None or target == view.last_goto_e7:
            return
        view.last_goto_e7 = target
        view.goto_cost_m += float(distance_m(view.lat_deg, view.lon_deg, goto.lat_e7 / DEG_E7, goto.lon_e7 / DEG_E7))
        self.version += 1


def primitive_news(p: PrimitiveView, moves: bool = True) -> tuple[object, ...]:
    """A PRIMITIVE_STATUS as news: all it says but when it was stamped (a repeat is no news); `moves` False:
    nor the distances a Go To runs down."""
    distances = (p.distance_to_go_m, p.distance_travelled_m) if moves else ()
    return (p.primitive, p.progress, p.target_lat_e7, p.target_lon_e7, *distances, p.slot, p.mussel_id)
