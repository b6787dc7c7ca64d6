"""The operator's commands to an aPad, and how the console carries them out through the aPad API.

The commands are plain values the UI puts on the runner's queue; `execute` runs one on the world
thread (or on an aPad loop's process, with that loop's API on its clock). `leave_holding` is what
quitting does, in a bounded time: hold every aPad and send the floating aMussels back down.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from apad_sitl.vocabulary import Latch, Primitive, Progress
from gcs.api import ApadApi, CommandError
from gcs.mission.world import World
from mussel_sim.vocabulary import MusselCommand, MusselState

QUIT_ACK_S = 0.3  # quitting waits this long (mission time) for each aPad's ACK of its hold
QUIT_FLUSH_S = 0.1  # and this long for the last commands to go out


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


class Refused(Exception):
    """An operator command the console refuses itself, nothing sent; `words` say why."""

    def __init__(self, words: str) -> None:
        super().__init__(words)
        self.words = words


ACTIONS: dict[type, str] = {Hold: "override", GoToMussel: "goto", DockMussel: "dock", UndockMussel: "undock"}


def action_of(command: OperatorCommand) -> tuple[str, dict[str, int]]:
    """The command as the event log names it, and its aMussel if it has one."""
    mussel = getattr(command, "mussel_id", None)
    return ACTIONS[type(command)], ({} if mussel is None else {"mussel": mussel})


def words_of(exc: Exception) -> str:
    """Why a command did not happen, in the operator's words (`gcs.link.commands.refusal_words`)."""
    if isinstance(exc, CommandError | Refused):
        return exc.words
    return str(exc).strip("'\"")  # a LookupError: "no status heard from aMussel 3", "aPad 2 has not been heard"


def execute(api: ApadApi, apad: int, command: OperatorCommand, name: str = "aPad") -> tuple[str, dict[str, int]]:
    """Send `command` to aPad `apad`: the notice the operator reads and what the event log adds (the
    slot). `name`: how the aPad is called ("aPad" with one, "aPad 2" in a swarm). Raises `Refused`,
    `CommandError` or `LookupError`."""
    on = "" if name == "aPad" else f" on {name}"  # one aPad: the notices it always had
    match command:
        case Hold():
            api.hold(apad)
            return f"override: {name} holding, loop paused", {}
        case GoToMussel(mussel_id):
            api.go_to(api.get_location(mussel_id), apad_id=apad)
            return f"manual: {name} going to aMussel {mussel_id}, loop paused", {}
        case DockMussel(mussel_id):
            free = api.apad(apad).free_slots()
            if not free:
                raise Refused(f"no free slot{on}")
            api.command_mussel(mussel_id, MusselCommand.SURFACE, apad)
            api.docking(True, free[0], mussel_id, apad)
            return f"manual: {name} docking aMussel {mussel_id} in slot {free[0]}, loop paused", {"slot": free[0]}
        case UndockMussel(mussel_id):
            slots = [s.slot for s in api.slots(apad) if s.mussel_id == mussel_id and s.latch == Latch.LATCHED]
            if not slots:
                raise Refused(f"aMussel {mussel_id} is not docked{on}")
            api.docking(False, slots[0], mussel_id, apad)
            return f"manual: {name} undocking aMussel {mussel_id} from slot {slots[0]}, loop paused", {"slot": slots[0]}
    raise AssertionError(command)


def docking(world: World, apad: int) -> bool:
    """Whether aPad `apad` is in the middle of a dock or undock (never to be interrupted)."""
    view = world.link.vehicles.get(apad)
    return view is not None and view.primitive.primitive in (Primitive.DOCK, Primitive.UNDOCK) and (
        view.primitive.progress == Progress.IN_PROGRESS
    )


def leave_holding(world: World, notice: Callable[[str], None]) -> list[int]:
    """Quit, bounded: hold every aPad heard (one send and a short wait for its ACK: a lost link must
    not keep the console), and send every aMussel floating outside a slot back down. A dock in
    progress is left to its latch (the aPad holds in place: in reach it latches; if not, the aMussel
    floats and the whereabouts say so), and so is an aMussel still surfacing (it takes no sink
    command before it floats). Returns those left at the surface."""
    heard = [a.system_id for a in world.scenario.apads if a.system_id in world.link.vehicles]
    for apad in heard:
        try:
            world.api.hold(apad, timeout_s=QUIT_ACK_S, retries=0)
        except CommandError as exc:
            notice(f"quitting: {exc.words} to the hold of aPad {apad}")
    if not heard:
        return []
    api = world.api
    held = {s.mussel_id for a in heard for s in api.slots(a) if s.mussel_id}
    up = {m: api.mussels[m].state for m in api.mussels.select((MusselState.SURFACING, MusselState.FLOATING))
          if m not in held}
    for mussel_id, state in up.items():
        if state == MusselState.FLOATING:
            api.command_mussel(mussel_id, MusselCommand.SINK, heard[0])
    world.clock.sleep(QUIT_FLUSH_S)  # let the last commands go out before the link closes
    return sorted(m for m, state in up.items() if state != MusselState.FLOATING)


__all__ = ["CommandError", "DockMussel", "GoToMussel", "Hold", "OperatorCommand", "Refused", "UndockMussel", "execute"]
