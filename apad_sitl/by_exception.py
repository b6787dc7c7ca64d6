"""Report by exception, the arithmetic of the ideal-link mode's telemetry (`apad_sitl.streams` uses it).

On an ideal link (`SitlVehicle(..., ideal_link=True)`) a stream sends only when its message differs
from the last one sent of that stream, time stamps aside (`report_key`), at the instants of its
period as the GCS set it: the GCS then knows at every instant what a stream sending every period
would have told it, and is told nothing twice. A stream of DOCK_SLOT_STATUS is one per slot.

The battery's volts differ in steps of `BATTERY_STEP_MV`: a report goes when they leave the step they
were in (a dead band, as DIS's dead-reckoning thresholds), so the GCS's battery is within a step of
what a stream sending every period would say. A resting aPad's millivolts change every few seconds,
each change a report, with nothing a wait reads changing between (the mission loop's budgets and
thresholds are volts, not millivolts).

While the hull rests with its physics task parked, a stream's next report is the first instant of
its grid at which its message would differ (`first_change`, over the rest's closed form); none, and
it is parked until the rest ends. `next_on_grid` puts a stream back on the grid it never left.

Pure but for the scheduler's place in time, which `next_on_grid` reads.
"""

from __future__ import annotations

import bisect
from collections.abc import Callable, Sequence
from typing import Any, Protocol, cast

from apad_sitl.vehicle import VehicleState
from mavlink_dialect import mavlink
from missiontime import Scheduler, Task

# Fields that stamp a message with the time it was sent: they differ at every send, and say nothing new.
STAMPS = frozenset({"time_boot_ms", "time_usec", "time_us", "time_unix_usec"})
BATTERY_STEP_MV = 10  # the battery's dead band: 0.2 % of the pack's 5.5 V
# Fields of millivolts (a list: the first, the pack's voltage; the rest are UINT16_MAX) in steps of BATTERY_STEP_MV.
_STEPPED = frozenset({(mavlink.MAVLINK_MSG_ID_SYS_STATUS, "voltage_battery"),
                      (mavlink.MAVLINK_MSG_ID_BATTERY_STATUS, "voltages")})
_STEPPED_IDS = frozenset(msg_id for msg_id, _ in _STEPPED)
_fields: dict[int, tuple[str, ...]] = {}  # message id -> its fields but the stamps


class HullAhead(Protocol):
    """A parked hull's rest ahead (`apad_sitl.parking.RestAhead`)."""

    @property
    def end(self) -> VehicleState:
        """The hull once the rest has done all it can."""
        ...

    @property
    def still_us(self) -> int | None:
        """When it gets there; None: with no closed form (a charging rest)."""
        ...

    def hull_at(self, t_us: int) -> VehicleState: ...


class Resting(Protocol):
    """The physics task as the streams see it (`apad_sitl.parking.PhysicsTicks`)."""

    def ahead(self) -> HullAhead | None:
        """The rest ahead while the task is parked; None while it ticks."""
        ...


def report_key(msg: mavlink.MAVLink_message) -> tuple[Any, ...]:
    """What a message tells, time stamps aside and its battery in steps: equal keys report the same."""
    msg_id = msg.get_msgId()
    fields = _fields.get(msg_id)
    if fields is None:
        fields = _fields[msg_id] = tuple(f for f in msg.get_fieldnames() if f not in STAMPS)
    if msg_id in _STEPPED_IDS:
        return tuple(_stepped(getattr(msg, f)) if (msg_id, f) in _STEPPED else getattr(msg, f) for f in fields)
    return tuple(getattr(msg, f) for f in fields)


def _stepped(mv: int | list[int]) -> int | tuple[int, ...]:
    if isinstance(mv, list):
        return (mv[0] // BATTERY_STEP_MV, *mv[1:])
    return mv // BATTERY_STEP_MV


def stream_of(msg: mavlink.MAVLink_message) -> tuple[int, int]:
    """The stream a message belongs to: its id, and for DOCK_SLOT_STATUS its slot (0 for the others)."""
    msg_id = msg.get_msgId()
    return msg_id, (cast(Any, msg).slot if msg_id == mavlink.MAVLINK_MSG_ID_DOCK_SLOT_STATUS else 0)


def keys(built: Sequence[mavlink.MAVLink_message]) -> list[tuple[Any, ...]]:
    return [report_key(m) for m in built]


def first_change(differs: Callable[[int], bool], k_end: int) -> int:
    """The least k in 1..`k_end` with `differs(k)`, given that `differs` is monotone (false, then true for
    good) and true at `k_end`: doubling from 1, then halving; about 2 log2(k) calls, most often 1 or 2."""
    lo, hi = 0, 1
    while hi < k_end and not differs(hi):
        lo, hi = hi, min(2 * hi, k_end)
    return lo + 1 + bisect.bisect_left(range(lo + 1, hi), True, key=differs)  # differs(hi) is known (or given)


def next_on_grid(task: Task, scheduler: Scheduler) -> int:
    """The next instant of `task`'s grid (its `next_us` stepped by whole periods, back or forth) that a
    task ticking throughout would still run: now, if now is on the grid and the task's turn in this
    instant has not come (the task running has a lower order), else the first after now."""
    now, period = scheduler.now_us, task.period_us
    ahead = (task.next_us - now) % period
    running = scheduler.running
    if ahead == 0 and (running is None or running >= task.order):
        ahead = period
    return now + ahead
