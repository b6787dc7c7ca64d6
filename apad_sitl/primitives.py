"""The aPad's mission primitives as a pure state machine: Go To Point, Hold Position, Dock, Undock.

`PrimitiveState` holds the running primitive and the four docking slots. Commands (`go_to`,
`hold`, `dock`, `undock`) return a new state; `step` advances latches and progress by `dt_s`;
`velocity_setpoint` is the position controller the physics step feeds to the vehicle model.
No clock, no I/O. The enums are the dialect's typed ones so the wire values have one source.

Control (Go To and every primitive that holds a point): a desired ground velocity toward the
target, at most the Go To speed, HOLD_KP * distance near the target and sqrt(ACCEL_MAX * d) so
the hull can brake at half ACCEL_MAX; plus HOLD_KD times the ground-velocity error, which pushes
back against the current. Under a steady current c the aPad settles c / (HOLD_KP * (1 + HOLD_KD))
down-current of its target (0.27 m at 0.2 m/s with the defaults). The velocity-error loop is
closed through one physics step, so HOLD_KD < 1 keeps it from ringing.

Dock and Undock are mechanical: each slot has its own latch timer; the primitive mirrors the
slot it commanded and holds position meanwhile. A dock whose aMussel leaves DOCK_REACH before
the latch closes fails and reopens the latch.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from enum import IntEnum

from apad_sitl.params import ApadParams
from apad_sitl.vehicle import VehicleState
from apad_sitl.vocabulary import N_SLOTS, Latch, Primitive, Progress

IN_PROGRESS = Progress.IN_PROGRESS  # == 1, the paper's `goto_status == 1`


class Refusal(IntEnum):
    """Why a Dock/Undock was refused; the vehicle sends it in COMMAND_ACK.result_param2."""

    BAD_SLOT = 1
    BAD_MUSSEL_ID = 2
    UNKNOWN_MUSSEL = 3
    OUT_OF_REACH = 4
    SLOT_OCCUPIED = 5
    ALREADY_DOCKED = 6
    SLOT_EMPTY = 7
    WRONG_MUSSEL = 8
    SLOT_BUSY = 9


REFUSAL_TEXT: dict[Refusal, str] = {  # short: the reason and its context fit one STATUSTEXT (50 chars)
    Refusal.BAD_SLOT: "slot must be 1..4",
    Refusal.BAD_MUSSEL_ID: "bad aMussel id",
    Refusal.UNKNOWN_MUSSEL: "never heard of it",
    Refusal.OUT_OF_REACH: "out of docking reach",
    Refusal.SLOT_OCCUPIED: "slot occupied",
    Refusal.ALREADY_DOCKED: "already docked",
    Refusal.SLOT_EMPTY: "slot empty",
    Refusal.WRONG_MUSSEL: "other aMussel in slot",
    Refusal.SLOT_BUSY: "slot busy releasing",
}


@dataclass(frozen=True)
class MusselFix:
    """The latest reported position of an aMussel, in the aPad's local frame."""

    x_m: float  # m, east of home
    y_m: float  # m, north of home
    docked: bool = False  # its last status says DOCKED (here or on another aPad)


@dataclass(frozen=True)
class SlotState:
    mussel_id: int = 0  # aMussel in (or entering/leaving) the slot; 0 when empty
    latch: Latch = Latch.OPEN
    charging: bool = False  # inductive charger powered (LATCHED only)
    timer_s: float = 0.0  # s left until CLOSING/RELEASING completes


EMPTY_SLOTS: tuple[SlotState, ...] = (SlotState(),) * N_SLOTS


@dataclass(frozen=True)
class PrimitiveState:
    kind: Primitive = Primitive.IDLE  # IDLE: thrusters idle, the hull drifts
    progress: Progress = Progress.NONE
    target_x_m: float = 0.0  # m east of home: the Go To target or the point held
    target_y_m: float = 0.0  # m north of home
    speed_mps: float = 0.0  # Go To speed, m/s; <= 0: SPEED_MAX
    radius_m: float = 0.0  # Go To victory radius, m; <= 0: WP_RADIUS
    slot: int = 0  # Dock/Undock slot, 1..4; 0 otherwise
    mussel_id: int = 0  # Dock/Undock aMussel; 0 otherwise
    slots: tuple[SlotState, ...] = EMPTY_SLOTS  # slot n is slots[n - 1]

    def slot_state(self, slot: int) -> SlotState:
        return self.slots[slot - 1]

    def docked_slot(self, mussel_id: int) -> int:
        """The slot holding (or closing on, or releasing) `mussel_id`; 0 if none."""
        for i, s in enumerate(self.slots):
            if s.mussel_id == mussel_id and s.latch != Latch.OPEN:
                return i + 1
        return 0


def _settled(state: PrimitiveState) -> bool:
    """True if the controller is holding its target point (not travelling, not idle)."""
    if state.kind == Primitive.IDLE:
        return False
    return not (state.kind == Primitive.GOTO and state.progress == Progress.IN_PROGRESS)


def hold_point(state: PrimitiveState, x_m: float, y_m: float) -> tuple[float, float]:
    """Where a primitive started now should hold: the point already held, else where the hull is."""
    return (state.target_x_m, state.target_y_m) if _settled(state) else (x_m, y_m)


def _with_slot(state: PrimitiveState, slot: int, new: SlotState) -> PrimitiveState:
    slots = list(state.slots)
    slots[slot - 1] = new
    return replace(state, slots=tuple(slots))


def go_to(
    state: PrimitiveState, x_m: float, y_m: float, speed_mps: float = 0.0, radius_m: float = 0.0
) -> PrimitiveState:
    """Start Go To Point. `speed_mps`, `radius_m` <= 0 mean SPEED_MAX, WP_RADIUS (read each step)."""
    return replace(
        state, kind=Primitive.GOTO, progress=IN_PROGRESS, target_x_m=x_m, target_y_m=y_m,
        speed_mps=speed_mps, radius_m=radius_m, slot=0, mussel_id=0,
    )


def hold(state: PrimitiveState, x_m: float, y_m: float) -> PrimitiveState:
    """Start Hold Position at (x_m, y_m)."""
    return replace(
        state, kind=Primitive.HOLD, progress=IN_PROGRESS, target_x_m=x_m, target_y_m=y_m,
        speed_mps=0.0, radius_m=0.0, slot=0, mussel_id=0,
    )


def idle(state: PrimitiveState) -> PrimitiveState:
    """Stop controlling position (thrusters idle); latches carry on."""
    return replace(state, kind=Primitive.IDLE, progress=Progress.NONE, slot=0, mussel_id=0)


def set_speed(state: PrimitiveState, speed_mps: float) -> PrimitiveState:
    """Change the running Go To's speed (<= 0: SPEED_MAX)."""
    return replace(state, speed_mps=speed_mps) if state.kind == Primitive.GOTO else state


def dock(
    state: PrimitiveState,
    slot: int,
    mussel_id: int,
    x_m: float,
    y_m: float,
    mussels: Mapping[int, MusselFix],
    params: ApadParams,
) -> tuple[PrimitiveState, Refusal | None]:
    """Start docking `mussel_id` into `slot` with the aPad at (x_m, y_m).

    A repeat of a dock already closing or latched on the same aMussel and slot is accepted and
    changes nothing (a GCS retrying after a lost ACK must not restart the latch).
    """
    if not 1 <= slot <= N_SLOTS:
        return state, Refusal.BAD_SLOT
    if not 1 <= mussel_id <= 0xFFFF:
        return state, Refusal.BAD_MUSSEL_ID
    current = state.slot_state(slot)
    if current.mussel_id == mussel_id and current.latch in (Latch.CLOSING, Latch.LATCHED):
        return state, None
    if state.docked_slot(mussel_id):
        return state, Refusal.ALREADY_DOCKED
    if current.latch == Latch.RELEASING:
        return state, Refusal.SLOT_BUSY
    if current.latch != Latch.OPEN:
        return state, Refusal.SLOT_OCCUPIED
    fix = mussels.get(mussel_id)
    if fix is None:
        return state, Refusal.UNKNOWN_MUSSEL
    if fix.docked:
        return state, Refusal.ALREADY_DOCKED
    if math.hypot(fix.x_m - x_m, fix.y_m - y_m) > params.dock_reach_m:
        return state, Refusal.OUT_OF_REACH
    hx, hy = hold_point(state, x_m, y_m)
    state = _with_slot(state, slot, SlotState(mussel_id, Latch.CLOSING, False, params.dock_time_s))
    return replace(
        state, kind=Primitive.DOCK, progress=IN_PROGRESS, target_x_m=hx, target_y_m=hy,
        speed_mps=0.0, radius_m=0.0, slot=slot, mussel_id=mussel_id,
    ), None


def undock(
    state: PrimitiveState, slot: int, expected_mussel_id: int, x_m: float, y_m: float, params: ApadParams
) -> tuple[PrimitiveState, Refusal | None]:
    """Release `slot` (aborting a dock still closing). `expected_mussel_id` 0 releases whatever is there.

    A repeat while the same aMussel is already releasing is accepted and changes nothing.
    """
    if not 1 <= slot <= N_SLOTS:
        return state, Refusal.BAD_SLOT
    if not 0 <= expected_mussel_id <= 0xFFFF:
        return state, Refusal.BAD_MUSSEL_ID
    current = state.slot_state(slot)
    if current.latch == Latch.OPEN:
        return state, Refusal.SLOT_EMPTY
    if expected_mussel_id and current.mussel_id != expected_mussel_id:
        return state, Refusal.WRONG_MUSSEL
    if current.latch == Latch.RELEASING:
        return state, None
    hx, hy = hold_point(state, x_m, y_m)
    state = _with_slot(state, slot, SlotState(current.mussel_id, Latch.RELEASING, False, params.undock_time_s))
    return replace(
        state, kind=Primitive.UNDOCK, progress=IN_PROGRESS, target_x_m=hx, target_y_m=hy,
        speed_mps=0.0, radius_m=0.0, slot=slot, mussel_id=current.mussel_id,
    ), None


_TIMED = frozenset((Latch.CLOSING, Latch.RELEASING))  # latches whose timers run in `step`


def step(
    state: PrimitiveState,
    x_m: float,
    y_m: float,
    mussels: Mapping[int, MusselFix],
    params: ApadParams,
    dt_s: float,
) -> PrimitiveState:
    """Advance latch timers, check docking reach, update progress; the aPad is at (x_m, y_m)."""
    kind, progress = state.kind, state.progress
    slots = list(state.slots)
    for i, s in enumerate(slots):
        if s.latch not in _TIMED:
            continue  # open or latched: nothing runs (most slots, most steps)
        slot = i + 1
        mine = state.slot == slot and state.mussel_id == s.mussel_id
        if s.latch == Latch.CLOSING:
            fix = mussels.get(s.mussel_id)
            if fix is None or math.hypot(fix.x_m - x_m, fix.y_m - y_m) > params.dock_reach_m:
                slots[i] = SlotState()
                if mine and kind == Primitive.DOCK and progress == IN_PROGRESS:
                    progress = Progress.FAILED
            elif s.timer_s - dt_s <= 0.0:
                slots[i] = SlotState(s.mussel_id, Latch.LATCHED, True, 0.0)
                if mine and kind == Primitive.DOCK and progress == IN_PROGRESS:
                    progress = Progress.DONE
            else:
                slots[i] = replace(s, timer_s=s.timer_s - dt_s)
        elif s.latch == Latch.RELEASING:
            if s.timer_s - dt_s <= 0.0:
                slots[i] = SlotState()
                if mine and kind == Primitive.UNDOCK and progress == IN_PROGRESS:
                    progress = Progress.DONE
            else:
                slots[i] = replace(s, timer_s=s.timer_s - dt_s)

    if kind in (Primitive.GOTO, Primitive.HOLD) and progress == IN_PROGRESS:
        radius = state.radius_m if state.radius_m > 0.0 else params.wp_radius_m
        if math.hypot(state.target_x_m - x_m, state.target_y_m - y_m) <= radius:
            progress = Progress.DONE

    new_slots = tuple(slots)
    if progress == state.progress and new_slots == state.slots:
        return state
    return replace(state, progress=progress, slots=new_slots)


def velocity_setpoint(state: PrimitiveState, vehicle: VehicleState, params: ApadParams) -> tuple[float, float]:
    """Water-relative velocity setpoint (east, north) m/s for the vehicle model."""
    if state.kind == Primitive.IDLE:
        return 0.0, 0.0
    ex, ey = state.target_x_m - vehicle.x_m, state.target_y_m - vehicle.y_m
    dist = math.hypot(ex, ey)
    speed = params.speed_max_mps
    if state.kind == Primitive.GOTO and state.speed_mps > 0.0:
        speed = min(speed, state.speed_mps)
    approach = min(speed, params.hold_kp_per_s * dist, math.sqrt(params.accel_max_mps2 * dist))
    vdx, vdy = (ex * approach / dist, ey * approach / dist) if dist > 1e-9 else (0.0, 0.0)
    kd = params.hold_kd
    return vdx + kd * (vdx - vehicle.vx_mps), vdy + kd * (vdy - vehicle.vy_mps)
