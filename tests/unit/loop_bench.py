"""A scripted world and a recording crew: the loop's phases (`gcs.loop.phases`, `home_charge`, `sleep_orders`,
`turns`) tested alone, as the SITL parts are on `test_sitl_part_host.RecordingHost`.

`loop_world.World` is what the test sets: plain dicts of the fleet as the GCS would know it (states, batteries,
where each aMussel is and goes back to, the aPad's slots, position and battery); `loop_world.ScriptedKnowledge`
answers `FleetKnowledge`'s reads from it. `RecordingActions` records every `ApadActions` command and wait in
order (`Call`: name and arguments), answers from a script (`fail`), and applies to the world what a phase reads
back: a Go To moves the aPad, a dock that succeeds puts the aMussel on its slot, a call-up floats it by the next
wait (or whatever `World.rises_to` says), an undock frees the slot, a sink sends it down. Its `wait_until`
records the wait, makes the test's next scripted change (`then`; one may come as a Go To arrives instead) and
returns what `done()` says; an untimed wait never done ends the mission, as a real one would.

Real parts: `LoopBook` (over the scripted knowledge), `LoopStatus`, `LoopControl`, `LoopLog` over an `EventLog`
on a `VirtualClock`, and `LoopSettings` built from a shipped scenario (`loop_world.loop_settings`). Reads are
not recorded (`link_up` included): a phase's reads are the world's answers, its commands the record.
"""

from __future__ import annotations

import ast
import inspect
import textwrap
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, cast

from loop_world import ScriptedKnowledge, World, loop_settings

from apad_sitl.vocabulary import Latch
from gcs.belief.duty import Duty
from gcs.link.apad_api import Location
from gcs.link.telemetry import SlotView
from gcs.loop.actions import ApadActions
from gcs.loop.book import LoopBook
from gcs.loop.control import EndReason, LoopControl, LoopLog, LoopStatus, MissionEnded, Phase
from gcs.loop.crew import Crew
from gcs.loop.fleet_knowledge import FleetKnowledge
from gcs.records.events import EventLog
from gcs.scenario.reader import load_scenario
from missiontime import VirtualClock
from mussel_sim.geo import LocalFrame
from mussel_sim.vocabulary import MusselState

APAD_ID = 1


@dataclass(frozen=True)
class Call:
    """One command or wait a phase made: its name and arguments (a wait's condition left out)."""

    name: str
    args: tuple[Any, ...] = ()


class RecordingActions:
    """`ApadActions` recorded, scripted, and acting on a `World` (same public names and signatures; no
    `api` or `pace`: a phase that reached past its actions fails here)."""

    def __init__(self, knows: ScriptedKnowledge, control: LoopControl, status: LoopStatus, log: LoopLog) -> None:
        self.knows = knows
        self.clock = knows.clock
        self.settings = knows.settings
        self.apad_id = knows.apad_id
        self.control = control
        self.status = status
        self.leaving: set[int] = set()
        self.calls: list[Call] = []
        self.failing: set[tuple[str, object]] = set()
        self.changes: list[tuple[Phase | None, str, Callable[[], None]]] = []  # the test's (`then`)
        self.rising: list[int] = []  # called up, floating by the next wait
        self._log = log

    # --- the script

    def fail(self, name: str, key: object = None) -> None:
        """Make `name` fail: for `key` (a Go To's target, the aMussel of the others), or always (hold)."""
        self.failing.add((name, key))

    def then(self, change: Callable[[], None], phase: Phase | None = None, at: str = "wait_until") -> None:
        """A change of the world, made in the order given, each at the next `wait_until` after the one before
        it (before `done()` is asked), or at the end of the next `go_to` that arrives (`at`); with `phase`,
        at the next one in that phase."""
        self.changes.append((phase, at, change))

    def _change(self, at: str) -> None:
        """The test's next change, if it is due here."""
        if self.changes and self.changes[0][0] in (None, self.status.phase) and self.changes[0][1] == at:
            self.changes.pop(0)[2]()

    def names(self) -> list[str]:
        return [c.name for c in self.calls]

    def args(self, name: str) -> list[tuple[Any, ...]]:
        return [c.args for c in self.calls if c.name == name]

    def _call(self, name: str, *args: Any) -> None:
        self.calls.append(Call(name, args))

    def _fails(self, name: str, key: object = None) -> bool:
        return (name, key) in self.failing

    @property
    def _world(self) -> World:
        return self.knows.world

    # --- primitives with waiting

    def go_to(self, target: Location, interruptible: bool = True) -> bool:
        self._call("go_to", target, interruptible)
        if self._fails("go_to", target):
            return False
        self._world.position = target
        self._change("go_to")
        return True

    def dock(self, slot: int, mussel_id: int) -> bool:
        self._call("dock", slot, mussel_id)
        if self._fails("dock", mussel_id):
            return False
        self._world.slots[slot] = SlotView(slot, mussel_id, Latch.LATCHED, charging=True)
        self._world.states[mussel_id] = MusselState.DOCKED
        return True

    def undock(self, slot: int, mussel_id: int) -> bool:
        self._call("undock", slot, mussel_id)
        if self._fails("undock", mussel_id):
            return False
        w = self._world
        w.slots[slot] = SlotView(slot)
        w.states[mussel_id] = MusselState.FLOATING
        w.locations[mussel_id] = w.position
        w.surfaced.add(mussel_id)
        return True

    def sink(self, mussel_id: int) -> None:
        self._call("sink", mussel_id)
        if self._fails("sink", mussel_id):  # it does not answer: still floating
            return
        self._world.states[mussel_id] = MusselState.SINKING
        self._world.surfaced.discard(mussel_id)

    def hold(self) -> bool:
        self._call("hold")
        return not self._fails("hold")

    def tell_to_sink(self, mussel_id: int) -> bool:
        self._call("tell_to_sink", mussel_id)
        if self._fails("tell_to_sink", mussel_id):
            return False
        self._world.states[mussel_id] = MusselState.SINKING
        self._world.surfaced.discard(mussel_id)
        return True

    def sleep_order(self, mussel_id: int, duty: Duty) -> bool:
        self._call("sleep_order", mussel_id, duty)
        return not self._fails("sleep_order", mussel_id)

    def slow_telemetry(self) -> None:
        self._call("slow_telemetry")

    def command(self, fn: Callable[..., None], *args: object, **kwargs: object) -> bool:
        self._call("command", getattr(fn, "__name__", str(fn)), *args)
        fn(*args, **kwargs)
        return True

    # --- the link

    def link_up(self) -> bool:
        return self._world.link_up

    def wait_for_link(self, timeout_s: float | None = None, interruptible: bool = True) -> bool:
        self._call("wait_for_link", timeout_s, interruptible)
        return self._world.link_up

    # --- waiting, ending, pausing

    def wait_until(self, done: Callable[[], bool], timeout_s: float | None = None, interruptible: bool = True,
                   holding_for_s: float = 0.0, **kwargs: object) -> bool:
        """Recorded; the aMussels called up rise, the test's next change is made, then `done()` answers.
        Untimed and not done: the mission ends here (interruptible), or the test is told it waits forever."""
        self._call("wait_until", timeout_s, interruptible, holding_for_s)
        w = self._world
        for m in self.rising:
            w.states[m] = w.rises_to.get(m, MusselState.FLOATING)
            if w.states[m] == MusselState.FLOATING:
                w.surfaced.add(m)
        self.rising.clear()
        self._change("wait_until")
        if done():
            return True
        if timeout_s is None:
            if not interruptible:
                raise AssertionError("an untimed, uninterruptible wait that is never done: it would wait forever")
            raise MissionEnded(EndReason.MISSION_TIME)
        return False

    def hold_for(self, dt_s: float) -> None:
        self._call("hold_for", dt_s)
        self.clock.sleep(dt_s)

    def sleep(self, dt_s: float, interruptible: bool = True) -> None:
        self._call("sleep", dt_s, interruptible)
        self.clock.sleep(dt_s)

    def check_end(self) -> None:
        self._call("check_end")
        if self.control.stop:
            raise MissionEnded(EndReason.OPERATOR)
        if self.clock.time() >= self.settings.mission.duration_s:
            raise MissionEnded(EndReason.MISSION_TIME)
        volts = self._world.battery_v
        if volts is not None and volts <= self.settings.battery_end_v:
            raise MissionEnded(EndReason.APAD_BATTERY)

    def begin_redeployment(self) -> None:
        self._call("begin_redeployment")
        self.leaving.clear()

    def let_go(self, mussel_id: int) -> None:
        self._call("let_go", mussel_id)
        self.leaving.add(mussel_id)

    def finish(self) -> None:
        self._call("finish")

    # --- calling up, the phase record

    def call_up_if_in_range(self, mussel_id: int) -> bool:
        """As the real one: one floating already needs no call; one the script puts out of range is not
        called. A call-up floats it by the next wait (`World.rises_to`)."""
        self._call("call_up_if_in_range", mussel_id)
        if self.knows.state(mussel_id) == MusselState.FLOATING:
            return True
        if self._fails("call_up_if_in_range", mussel_id):
            return False
        self._world.states[mussel_id] = MusselState.SURFACING
        self.rising.append(mussel_id)
        self._log("call_up", mussel=mussel_id, distance_m=round(self.knows.distance_to(mussel_id), 2))
        return True

    def set_phase(self, phase: Phase) -> None:
        self._call("set_phase", phase)
        if phase != self.status.phase or phase == Phase.IDLE_WAIT:
            self.status.phase = phase
            self._log("phase", phase=str(phase))


class Bench:
    """A recording crew over a scripted world, with a scenario's settings (pool12's: 4 slots, its home,
    thresholds 0.80 / 0.99, min_pool 4); the aPad starts at its home, every slot free."""

    def __init__(self, scenario: str = "pool12", strategy: str | None = None) -> None:
        self.scenario = s = load_scenario(scenario)
        self.home = Location(s.apad.home_lat_deg, s.apad.home_lon_deg)
        self.frame = LocalFrame(*self.home)
        self.settings = loop_settings(s, list(range(1, s.fleet.count + 1)))
        self.clock = VirtualClock()
        self.events = EventLog()
        self.log = LoopLog(self.events, self.clock)
        self.world = World(position=self.home)
        self.status = LoopStatus(strategy=strategy or s.mission.collect_strategy)
        self.control = LoopControl()
        self.knows = ScriptedKnowledge(self.world, self.clock, self.settings, APAD_ID, self.status.orders)
        knows = cast(FleetKnowledge, self.knows)  # the scripted reads stand in for the real ones
        self.book = LoopBook(knows, self.status.orders, self.log)
        self.act = RecordingActions(self.knows, self.control, self.status, self.log)
        self.crew = Crew(knows, self.book, cast(ApadActions, self.act), self.status, self.control, self.log)

    def at(self, east_m: float, north_m: float) -> Location:
        """The point this far east and north of the aPad's home."""
        lat, lon = self.frame.to_geodetic(east_m, north_m)
        return Location(float(lat), float(lon))

    def mussel(self, mussel_id: int, east_m: float, north_m: float, battery: float = 0.5,
               state: MusselState = MusselState.ACTIVE, home: bool = True) -> Location:
        """An aMussel where it is (and its home there, unless `home` is False)."""
        w, where = self.world, self.at(east_m, north_m)
        w.states[mussel_id], w.batteries[mussel_id], w.locations[mussel_id] = state, battery, where
        if home:
            w.homes[mussel_id] = where
        if state == MusselState.FLOATING:
            w.surfaced.add(mussel_id)
        return where

    def on_slot(self, slot: int, mussel_id: int, battery: float = 1.0, home: Location | None = None) -> None:
        """An aMussel latched on `slot` (its home: `home`, if given)."""
        w = self.world
        w.slots[slot] = SlotView(slot, mussel_id, Latch.LATCHED, charging=True)
        w.states[mussel_id], w.batteries[mussel_id], w.locations[mussel_id] = MusselState.DOCKED, battery, w.position
        if home is not None:
            w.homes[mussel_id] = home

    def logged(self, *kinds: str) -> list[tuple[str, dict[str, Any]]]:
        """Events logged, in order: of `kinds`, or every one but the phase changes."""
        return [(e.kind, e.fields) for e in self.events.events
                if (e.kind in kinds if kinds else e.kind != "phase")]

    def kinds(self) -> list[str]:
        return [kind for kind, _ in self.logged()]


# --- keeping the fakes honest -------------------------------------------------------------------------

def public_names(cls: type) -> set[str]:
    """A class's public methods and properties, and the public attributes its `__init__` sets."""
    names = {n for n, _ in inspect.getmembers(cls) if not n.startswith("_")}
    tree = ast.parse(textwrap.dedent(inspect.getsource(cls.__init__)))  # type: ignore[misc]
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store) and \
                isinstance(node.value, ast.Name) and node.value.id == "self" and not node.attr.startswith("_"):
            names.add(node.attr)
    return names


def same_signature(real: Callable[..., Any], fake: Callable[..., Any]) -> bool:
    """The same parameters (names, kinds, defaults); a fake's `**kwargs` takes a real keyword it lacks."""
    def params(fn: Callable[..., Any]) -> list[tuple[str, object, object]]:
        return [(p.name, p.kind, p.default) for p in inspect.signature(fn).parameters.values()]

    theirs, ours = params(real), params(fake)
    if theirs == ours:
        return True
    if ours and ours[-1][1] == inspect.Parameter.VAR_KEYWORD:
        ours = ours[:-1]
        theirs = [p for p in theirs if p[0] in {o[0] for o in ours} or p[2] is inspect.Parameter.empty]
    return theirs == ours
