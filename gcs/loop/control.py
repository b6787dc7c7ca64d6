"""The energy-sharing loop's vocabulary and settings: its phases, why it ends, the operator's
controls, the status it shows, and its voice in the mission's event log."""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import StrEnum
from typing import TYPE_CHECKING

from gcs.belief.duty import OrdersSent
from gcs.belief.energy_budget import EnergyBudget
from gcs.records.events import EventLog
from gcs.scenario.reader import MissionConfig
from missiontime import Clock
from mussel_sim.battery import DEFAULT_CHARGE, DEFAULT_DISCHARGE, DischargeProfile, discharge_profile

if TYPE_CHECKING:
    from gcs.belief.duty import Duty


class Phase(StrEnum):
    IDLE_WAIT = "idle wait"
    PLAN_COLLECT = "plan collection"
    COLLECT = "collect"
    CHARGING_WAIT = "charging wait"
    PLAN_REDEPLOY = "plan redeployment"
    REDEPLOY = "redeploy"
    HOME_CHARGE = "home charge"  # gone home to its charger: the next trip would not be covered
    ENDED = "ended"


class EndReason(StrEnum):
    MISSION_TIME = "mission time"
    APAD_BATTERY = "aPad battery"
    OPERATOR = "operator stop"


class MissionEnded(Exception):
    def __init__(self, reason: EndReason) -> None:
        super().__init__(str(reason))
        self.reason = reason


@dataclass
class LoopControl:
    """What the operator may change while the loop runs (set from any thread)."""

    paused: bool = False
    stop: bool = False
    strategy: str | None = None  # a new collection strategy, taken at the next planning step
    lock: threading.Lock = field(default_factory=threading.Lock, repr=False)
    # Called before each of the loop's own waits (never inside a command's ACK wait): the console
    # runs the operator's queued commands here. True ends the mission at this wait (quit now).
    before_wait: Callable[[], bool] | None = field(default=None, repr=False)


@dataclass
class LoopStatus:
    """What the loop is doing, for the console and the results."""

    phase: Phase = Phase.IDLE_WAIT
    strategy: str = ""
    route: list[int] = field(default_factory=list)
    target_mussel: int = 0
    cost_m: float = 0.0  # the paper's movement cost: aPad-to-setpoint distance summed over Go To commands
    cycles: int = 0  # completed collect-charge-redeploy cycles
    end_reason: EndReason | None = None
    phase_s: dict[Phase, float] = field(default_factory=dict)  # mission seconds spent in each phase so far
    dockings: list[tuple[float, int]] = field(default_factory=list)  # (mission s, aMussel id) of each dock
    # Mission microseconds the aPad spent travelling, docking, holding (gcs.mission.time_accounting)
    apad_time_us: dict[str, int] = field(default_factory=dict)
    strategy_failures: int = 0  # planning steps the strategy failed (cautious planned them instead)
    home_charges: int = 0  # times the aPad went home and charged (gcs.loop.home_charge)
    orders: OrdersSent = field(default_factory=OrdersSent)  # the sleep orders sent (FleetKnowledge plans on them)
    # Failed dockings by what became of the aMussel (gcs.loop.failed_docking), and the reason of each one
    # it left off its position (the run's whereabouts repeat it)
    failed_dockings: dict[str, int] = field(default_factory=dict)
    off_position: dict[int, str] = field(default_factory=dict)


@dataclass(frozen=True)
class LoopSettings:
    mission: MissionConfig
    acoustic_range_m: float
    dock_reach_m: float
    battery_end_v: float
    surfacing_timeout_s: float = 120.0  # an aMussel that does not float by then is skipped
    # No aMussel is called up later than this before the mission end: once called up it is docked
    # (or sent down again) whatever the clock says, so it is never left at the surface.
    call_up_margin_s: float = 300.0
    poll_s: float = 0.5  # how often waits look again (mission time)
    apad_speed_mps: float = 0.5  # the aPad's cruise speed: how long a Go To may take before it is sent again
    mussel_surfacing_s: float = 20.0  # how long an aMussel takes to rise once called up (the fleet's)
    # The fleet's battery profiles (strategies plan with them): fleet.profile's discharge (a named model, or a
    # wake schedule's duty cycle) and charge.
    mussel_discharge: DischargeProfile = field(default_factory=lambda: discharge_profile(DEFAULT_DISCHARGE))
    mussel_charge: str = DEFAULT_CHARGE
    # Each simulated aMussel's scenario profile (gcs.belief.duty): its own drain and wake schedule; an
    # aMussel not in it (a real one) is planned on mussel_discharge, always on.
    duties: dict[int, Duty] = field(default_factory=dict)
    # Bounds on retrying (lossy links, a refusing aPad): at the bound the loop logs `gave_up`,
    # leaves that aMussel or step for now, and goes on.
    goto_attempts: int = 8  # Go To commands per target (after failsafe preemptions or trip timeouts)
    command_attempts: int = 5  # tries of one API command (each itself 4 sends with backoff)
    # Several aPads: a leg passing closer than this to another aPad (or its target) waits to set off.
    separation_m: float = 3.0
    separation_wait_s: float = 60.0
    # The aPad's energy (None: trips are not checked, as before) and where its home charger is.
    energy: EnergyBudget | None = None
    home: tuple[float, float] | None = None  # (lat, lon)

    def call_up_wait_s(self, duty: Duty) -> float:
        """How long a call-up may take to float an aMussel on `duty`: the loop's bound, or its longest wake
        gap and twice its rise (a sleep order given during the mission may sleep longer than the profiles)."""
        return max(self.surfacing_timeout_s, duty.longest_wait_s(self.mission.theta) + 2 * self.mussel_surfacing_s)


@dataclass(frozen=True)
class LoopLog:
    """One aPad loop's events, stamped with its clock's mission time; with several aPads each event
    names its aPad (`apad_id` set)."""

    events: EventLog
    clock: Clock
    apad_id: int | None = None

    def __call__(self, kind: str, **fields: object) -> None:
        if self.apad_id is not None:
            fields = {"apad": self.apad_id, **fields}
        self.events.emit(self.clock.time(), kind, **fields)
