"""The operator's commands to an aPad, and how the console carries them out through the aPad API.

The commands are plain values the UI puts on the runner's queue; `execute` runs one on the world
thread (or on an aPad loop's process, with that loop's API on its clock). `leave_holding` is what
quitting does to every aPad: let a dock or undock finish, then hold (and with quit-now, send any
surfaced aMussel back down).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from apad_sitl.vocabulary import Latch, Primitive, Progress
from gcs.api import ApadApi, CommandError
from gcs.mission.world import World
from mussel_sim.vocabulary import MusselCommand, MusselState

QUIT_DOCK_WAIT_S = 120.0  # quitting waits this long at most for a dock/undock to finish
SINK_MARGIN_S = 10.0  # quit-now waits for surfacing aMussels to float (then sinks them), this much extra


@dataclass(frozen=True)
class Hold:
    """Abort whatever the aPad does: Hold Position."""


@dataclass(frozen=True)
class GoToMussel:
    mussel_id: int


@dataclass(frozen=True)
class DockMussel:
    mussel_id: int


@dataclass(frozen=True)
class UndockMussel:
    mussel_id: int


OperatorCommand = Hold | GoToMussel | DockMussel | UndockMussel


def execute(api: ApadApi, apad: int, command: OperatorCommand, name: str = "aPad") -> str:
    """Send `command` to aPad `apad`; the notice the operator reads. `name`: how the aPad is called
    in it ("aPad" with one, "aPad 2" in a swarm). Raises `CommandError` or `LookupError`."""
    on = "" if name == "aPad" else f" on {name}"  # one aPad: the notices it always had
    match command:
        case Hold():
            api.hold(apad)
            return f"override: {name} holding, loop paused"
        case GoToMussel(mussel_id):
            api.go_to(api.get_location(mussel_id), apad_id=apad)
            return f"manual: {name} going to aMussel {mussel_id}, loop paused"
        case DockMussel(mussel_id):
            free = api.apad(apad).free_slots()
            if not free:
                return f"refused: no free slot{on}"
            api.command_mussel(mussel_id, MusselCommand.SURFACE, apad)
            api.docking(True, free[0], mussel_id, apad)
            return f"manual: {name} docking aMussel {mussel_id} in slot {free[0]}, loop paused"
        case UndockMussel(mussel_id):
            slots = [s.slot for s in api.slots(apad) if s.mussel_id == mussel_id and s.latch == Latch.LATCHED]
            if not slots:
                return f"refused: aMussel {mussel_id} is not docked{on}"
            api.docking(False, slots[0], mussel_id, apad)
            return f"manual: {name} undocking aMussel {mussel_id} from slot {slots[0]}, loop paused"
    raise AssertionError(command)


def docking(world: World, apad: int) -> bool:
    """Whether aPad `apad` is in the middle of a dock or undock (never to be interrupted)."""
    view = world.link.vehicles.get(apad)
    return view is not None and view.primitive.primitive in (Primitive.DOCK, Primitive.UNDOCK) and (
        view.primitive.progress == Progress.IN_PROGRESS
    )


def leave_holding(world: World, now: bool, notice: Callable[[str], None]) -> None:
    """Quit: let every dock or undock finish, then hold every aPad heard (the loops already did if
    they ran); `now`: also sink what surfaced. Raises `CommandError`."""
    heard = [a.system_id for a in world.scenario.apads if a.system_id in world.link.vehicles]
    if not heard:
        return
    deadline = world.clock.time() + QUIT_DOCK_WAIT_S
    while any(docking(world, a) for a in heard) and world.clock.time() < deadline:
        notice("quitting: waiting for the dock to finish")
        world.clock.sleep(0.2)
    for apad in heard:
        world.api.hold(apad)
    if now:
        _sink_surfaced(world, heard, notice)
    world.clock.sleep(0.5)  # let the last commands go out before the link closes


def _sink_surfaced(world: World, apads: list[int], notice: Callable[[str], None]) -> None:
    """Nothing left floating where it cannot work: a surfacing aMussel is sunk once it floats."""
    api = world.api
    deadline = world.clock.time() + world.scenario.fleet.surfacing_time_s + SINK_MARGIN_S
    while world.clock.time() < deadline:
        docked = {s.mussel_id for a in apads for s in api.slots(a) if s.mussel_id}
        up = {m: api.mussels[m].state for m in api.mussels.select((MusselState.SURFACING, MusselState.FLOATING))
              if m not in docked}
        if not up:
            return
        notice(f"quitting now: sending aMussel {', '.join(map(str, sorted(up)))} back down")
        for mussel_id, state in up.items():
            if state == MusselState.FLOATING:
                api.command_mussel(mussel_id, MusselCommand.SINK, apads[0])
        world.clock.sleep(1.0)


__all__ = ["CommandError", "DockMussel", "GoToMussel", "Hold", "OperatorCommand", "UndockMussel", "execute"]
