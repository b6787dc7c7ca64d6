"""The operator's commands to an aPad, and how the console carries them out through the aPad API.

The commands are plain values the UI puts on the runner's `CommandQueue` (any thread); the queue
serves them on the world thread (or on an aPad loop's process, with that loop's API on its clock),
each run by `execute`, and logs them with the operator's other actions. `leave_holding` is what
quitting does, in a bounded time: hold every aPad and send the floating aMussels back down;
`log_whereabouts` then says where every aMussel was left. Once the operator has quit, no command
waits for an aPad whose link is lost (`LOST_S` without a heartbeat, LINK LOST on screen): it is
sent once and its retries are not waited out (a `quit_apad_silent` event says so, once per aPad),
so a silent aPad cannot hold the quit past its bound; a live aPad is waited for as ever.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass

from apad_sitl.vocabulary import Latch, Primitive, Progress
from gcs.console.link_health import LOST_S
from gcs.link.apad_api import ApadApi, CommandError
from gcs.link.command_protocol import command_words
from gcs.mission.world import World
from gcs.results.accounting import account
from missiontime import seconds_to_us, us_to_s
from mussel_sim.vocabulary import MusselCommand, MusselState

QUIT = "quit"  # the operator action that ends the console (`ConsoleRunner.request_quit` logs it)
QUIT_ACK_S = 0.3  # quitting waits this long (mission time) for each aPad's ACK of its hold (a silent one: none)
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
    """Why a command did not happen, in the operator's words (`gcs.link.command_protocol.refusal_words`)."""
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


class CommandQueue:
    """The operator's commands (each for an aPad) and other actions, queued by the UI from any thread;
    carried out and logged on a world thread only. `swarm`: several aPads (events name the aPad)."""

    def __init__(self, swarm: bool) -> None:
        self.swarm = swarm
        self._commands: list[tuple[int, OperatorCommand]] = []  # (target aPad, command)
        self._operator_events: list[tuple[str, dict[str, object]]] = []  # from the UI, logged on the world thread
        self._to_sink: dict[int, int] = {}  # aMussel -> the aPad to relay its sink command
        self._lock = threading.Lock()

    def put(self, apad: int, command: OperatorCommand) -> None:
        with self._lock:
            self._commands.append((apad, command))

    def log(self, action: str, fields: dict[str, object]) -> None:
        """An operator action for the event log (written by `flush`)."""
        with self._lock:
            self._operator_events.append((action, fields))

    def serve(self, world: World, api: ApadApi, serving: int | None, running: Callable[[int], bool],
              notice: Callable[[str], None]) -> None:
        """Run queued operator commands through `api`: those for aPad `serving`, and those whose aPad
        has no loop `running` to serve them (all when None)."""
        with self._lock:
            take = [c for c in self._commands if serving in (None, c[0]) or not running(c[0])]
            self._commands = [c for c in self._commands if not any(c is t for t in take)]
        if take:
            self.flush(world)  # what the operator did before (the pause a command brings) is logged first
        for sysid, command in take:
            action, fields = action_of(command)
            who = {"apad": sysid} if self.swarm else {}
            try:
                words, more = execute(api, sysid, command, f"aPad {sysid}" if self.swarm else "aPad")
                notice(words)
                world.events.emit(world.clock.time(), "operator", action=action, **who, **fields, **more)
            except (CommandError, LookupError, Refused) as exc:
                why = words_of(exc)
                notice(f"refused: {why}" if isinstance(exc, Refused) else f"refused: {action}: {why}")
                result = {"result": str(exc)} if isinstance(exc, CommandError) else {}
                world.events.emit(world.clock.time(), "refused", action=action, **who, **fields, why=why, **result)
                if isinstance(command, DockMussel) and isinstance(exc, CommandError):
                    self._to_sink[command.mussel_id] = sysid  # called up for a dock refused: not left afloat

    def sink_refused(self, world: World) -> None:
        """aMussels the operator called up for a dock that was refused: sent down once they float
        (a surfacing one takes no sink command); forgotten if they went anywhere else."""
        for mussel_id, sysid in list(self._to_sink.items()):
            state = world.api.mussels[mussel_id].state if mussel_id in world.api.mussels else None
            if state == MusselState.FLOATING:
                world.api.command_mussel(mussel_id, MusselCommand.SINK, sysid)
                world.events.emit(world.clock.time(), "operator_sink", mussel=mussel_id, why="its dock was refused")
            if state != MusselState.SURFACING:
                del self._to_sink[mussel_id]

    def flush(self, world: World) -> None:
        """Log the operator's actions the UI queued. The quit among them also stops every command's
        wait for an aPad that has fallen silent (`QuitWaits`), from this moment on."""
        with self._lock:
            taken, self._operator_events = self._operator_events, []
        for action, fields in taken:
            world.events.emit(world.clock.time(), "operator", action=action, **fields)
            if action == QUIT and world.link.commands.give_up is None:
                world.link.commands.give_up = QuitWaits(world)


class QuitWaits:
    """Once the operator has quit: a command to an aPad whose link is lost is not waited for (it
    answers nothing, and it holds by its own GCS failsafe); one heard lately is waited for as ever.
    The command client's `give_up` hook, called on the world thread in its ACK waits."""

    def __init__(self, world: World) -> None:
        self.world = world
        self.silent: set[int] = set()  # aPads whose answers the quit stopped waiting for

    def __call__(self, apad: int, command: int) -> str | None:
        """Why a command to aPad `apad` is not waited for, or None. The first time for an aPad, a
        `quit_apad_silent` event."""
        world = self.world
        view = world.link.vehicles.get(apad)
        if view is None:
            return None  # never heard: nothing is sent to it
        silent_us = world.clock.now_us - view.last_heartbeat_us
        if silent_us <= seconds_to_us(LOST_S):
            return None
        silent_s = round(us_to_s(silent_us), 1)
        if apad not in self.silent:
            self.silent.add(apad)
            world.events.emit(world.clock.time(), "quit_apad_silent", apad=apad, silent_s=silent_s,
                              command=command_words(command))
        return f"silent {silent_s:g} s (LINK LOST), its answer not waited for"


def docking(world: World, apad: int) -> bool:
    """Whether aPad `apad` is in the middle of a dock or undock (never to be interrupted)."""
    view = world.link.vehicles.get(apad)
    return view is not None and view.primitive.primitive in (Primitive.DOCK, Primitive.UNDOCK) and (
        view.primitive.progress == Progress.IN_PROGRESS
    )


def leave_holding(world: World, notice: Callable[[str], None]) -> list[int]:
    """Quit, bounded: hold every aPad heard (one send and a short wait for its ACK, none for one whose
    link is lost: a lost link must not keep the console), and send every aMussel floating outside a
    slot back down. A dock in progress is left to its latch (the aPad holds in place: in reach it
    latches; if not, the aMussel floats and the whereabouts say so), and so is an aMussel still
    surfacing (it takes no sink command before it floats). Returns those left at the surface."""
    heard = [a.system_id for a in world.scenario.apads if a.system_id in world.link.vehicles]
    for apad in heard:
        try:
            world.api.hold(apad, timeout_s=QUIT_ACK_S, retries=0)
        except CommandError as exc:
            notice(f"quitting: the hold of aPad {apad}: {exc.words}")
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


def log_whereabouts(world: World, surfacing: list[int]) -> None:
    """Where every aMussel is as the console quits: on the seabed, on a slot, or lost (and why);
    `surfacing`: those still rising, left to float (they take no sink command before they float)."""
    homes = {m: (h.lat, h.lon) for m, h in world.homes.items()}
    accounts = account(world.fleet.state, world.frame, homes, world.link.vehicles)
    world.events.emit(world.clock.time(), "whereabouts",
                      seabed=[a.mussel_id for a in accounts if a.where == "seabed"],
                      slot=[a.mussel_id for a in accounts if a.where == "slot"],
                      lost={str(a.mussel_id): a.detail for a in accounts if a.lost},
                      **({"left_surfacing": surfacing} if surfacing else {}))


__all__ = ["CommandError", "DockMussel", "GoToMussel", "Hold", "OperatorCommand", "Refused", "UndockMussel", "execute"]
