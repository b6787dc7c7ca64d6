"""What the fleet was told since its last step, queued for the next one (`FleetInputs`).

Call-ups and sinks (over MAVLink or heard acoustically), sleep orders, wake-up pings, and the docks and
releases the aPads' DOCK_SLOT_STATUS reports imply: which aMussel each (aPad, slot) holds is kept here,
so a report that says the same again queues nothing, and a dock let go before any step saw it cancels
out. Validation (whose ids, which senders) is the runner's (`mussel_sim.comms`); what arrives here is
taken. Pure: no clock (the mission time is passed in), no I/O.
"""

from __future__ import annotations

from collections.abc import Mapping

from mavlink_dialect import mavlink
from missiontime import US_PER_S
from mussel_sim.fleet_state import FleetInputs
from mussel_sim.vocabulary import MusselCommand

# DOCK_SLOT_STATUS latch values that hold an aMussel (the aPad's words, read here as wire values).
HOLDING_LATCHES = (mavlink.DOCK_LATCH_STATE_CLOSING, mavlink.DOCK_LATCH_STATE_LATCHED)
# Woken by the acoustic ping, an aMussel listens this long (mission time) for the call-up that follows:
# the GCS sends it right after the ping's answer, within the aPad's slot (under a second later). A few
# seconds' margin; not drawn from the battery (the duty cycle's mean drain stands for its wakes).
PING_LISTEN_US = 5 * US_PER_S


class PendingOrders:
    def __init__(self, ids: set[int]) -> None:
        """`ids`: the fleet's aMussels (a slot report of another id docks nothing here)."""
        self._ids = ids
        # Where we have docked each aMussel, and the reverse: (aPad, slot) -> aMussel id.
        self._docked_at: dict[int, tuple[int, int]] = {}
        self._slot_holds: dict[tuple[int, int], int] = {}
        self._surface: list[int] = []
        self._sink: list[int] = []
        self._dock: dict[int, tuple[int, int]] = {}
        self._release: list[int] = []
        self._sleep: list[tuple[int, float, float]] = []
        self._wake: list[int] = []
        self._listening_until_us: dict[int, int] = {}  # pinged awake: listening for a call-up until then

    @property
    def docked_at(self) -> dict[int, tuple[int, int]]:
        """Where the aPads' reports have each aMussel docked: id -> (aPad, slot) (a copy)."""
        return dict(self._docked_at)

    @property
    def pending(self) -> bool:
        """Whether anything waits for the next step."""
        return bool(self._surface or self._sink or self._dock or self._release or self._sleep or self._wake)

    @property
    def latches_changed(self) -> bool:
        """A dock or a release waits for the next step."""
        return bool(self._dock or self._release)

    def command(self, mussel_id: int, command: MusselCommand) -> None:
        """A call-up (SURFACE) or a SINK."""
        (self._surface if command == MusselCommand.SURFACE else self._sink).append(mussel_id)

    def sleep_order(self, mussel_id: int, interval_s: float, awake_s: float) -> None:
        self._sleep.append((mussel_id, interval_s, awake_s))

    def heard_acoustically(self, mussel_id: int, command: MusselCommand | None, now_us: int) -> None:
        """A `command` its modem heard (a call-up: SURFACE), or, with None, the wake-up ping. A pinged
        aMussel stays awake `PING_LISTEN_US` from `now_us` for the call-up that follows: heard in that
        time, it is taken at once (the ping woke it) instead of held for its next scheduled wake."""
        if command is None:
            self._wake.append(mussel_id)
            self._listening_until_us[mussel_id] = now_us + PING_LISTEN_US
            return
        if command == MusselCommand.SURFACE and self._listening_until_us.pop(mussel_id, -1) >= now_us:
            self._wake.append(mussel_id)  # in the step with the call-up: held as asleep, then let go at once
        self.command(mussel_id, command)

    def slot_status(self, apad: int, slot: int, mussel_id: int, latch: int) -> int | None:
        """An aPad's report of one slot: a change of what it holds queues a dock or a release; returns
        the aMussel whose release it queued, if any."""
        released = None
        key = (apad, slot)
        held = mussel_id if latch in HOLDING_LATCHES and mussel_id != 0 else 0
        prev = self._slot_holds.get(key)
        if prev is not None and prev != held:
            del self._slot_holds[key]
            del self._docked_at[prev]
            if prev in self._dock:  # docked and let go before any step saw it: nothing happened
                del self._dock[prev]
            else:
                self._release.append(prev)
                released = prev
        if held and held in self._ids and self._docked_at.get(held) != key:
            old = self._docked_at.get(held)
            if old is not None:  # moved to another slot: the old slot no longer claims it
                self._slot_holds.pop(old, None)
            self._docked_at[held] = key
            self._slot_holds[key] = held
            self._dock[held] = key
        return released

    def take(self, apads: Mapping[int, tuple[float, float]]) -> FleetInputs:
        """Everything queued, as the next step's inputs with the aPads' positions (metres); the queue
        is empty after."""
        inputs = FleetInputs.make(
            apads=apads,
            surface=self._surface,
            sink=self._sink,
            dock=[(m, a, s) for m, (a, s) in self._dock.items()],
            release=self._release,
            sleep=self._sleep,
            wake=self._wake,
        )
        self._surface, self._sink, self._dock, self._release, self._sleep, self._wake = [], [], {}, [], [], []
        return inputs
