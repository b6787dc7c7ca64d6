"""Sleep orders from the loop: a strategy with a sleep scheduler (`strategies.SCHEDULERS`) is asked, before
each round and before the aPad goes home to charge, which aMussels of this aPad's share to put to sleep
or wake back to always on; each decision is sent as the dialect's AMUSSEL_SLEEP_ORDER through the aPad
(`ApadApi.sleep_order`), logged (`sleep_order`) and planned with from then on (`LoopBook.ordered`).

Only aMussels always on by their scenario profile are ordered (a profile with a schedule of its own is
left to it), and only those on the seabed or sinking to it: one docked or rising is being charged.
"""

from __future__ import annotations

import math

import numpy as np

from gcs.belief.duty import Duty
from gcs.loop.crew import Crew
from gcs.strategies import SCHEDULERS, ScheduleInput
from gcs.strategies.keep_alive import SLEEP_AWAKE_S, SLEEP_INTERVAL_S
from mussel_sim.vocabulary import MusselState

ALWAYS_ON = Duty.of_order(0.0, 0.0)
ASLEEP = Duty.of_order(SLEEP_INTERVAL_S, SLEEP_AWAKE_S)
GOING_HOME = math.inf  # `start_s` before a home charge: no round comes for hours


def reschedule(crew: Crew, start_s: float = 0.0, why: str = "round") -> int:
    """Ask the strategy's scheduler (if it has one) and send its orders; how many were sent.
    `start_s`: mission seconds before the aPad can start its next collection."""
    scheduler = SCHEDULERS.get(crew.status.strategy)
    if scheduler is None:
        return 0
    inp = schedule_input(crew, start_s)
    if inp is None:
        return 0
    decisions = scheduler(inp)
    knows, act = crew.knows, crew.act
    sent = 0
    for mussel_id, wake in sorted(decisions.items()):
        duty = ALWAYS_ON if wake else ASLEEP
        if not act.sleep_order(mussel_id, duty):
            continue  # not sent (a gave_up event says so): planned as before, asked again next time
        crew.book.ordered(mussel_id, duty)
        sent += 1
        crew.log("sleep_order", mussel=mussel_id, interval_s=duty.interval_s, awake_s=duty.awake_s,
                 battery=round(knows.battery(mussel_id), 3), why=why)
    return sent


def schedule_input(crew: Crew, start_s: float) -> ScheduleInput | None:
    """The share's aMussels on the seabed, as the loop knows them; None if there are none."""
    knows = crew.knows
    # One still sinking from the last redeployment is ordered too: it is on the seabed in seconds, and a
    # home charge that starts right after a round would leave it always on for hours (seen: it depleted).
    deployed = knows.in_states((MusselState.ACTIVE, MusselState.SINKING))
    ids = [m for m in deployed if m in knows.homes and knows.serves(m)]
    slots = knows.slot_count()
    if not ids or not slots:  # nothing to order, or the aPad's slots not heard yet (the mission's first instant)
        return None
    theta = knows.settings.mission.theta
    where = [knows.location(m) for m in ids]
    profile = [knows.profile_duty(m) for m in ids]
    return ScheduleInput(
        mussel_ids=np.array(ids, np.int64),
        lat_deg=np.array([w.lat for w in where]),
        lon_deg=np.array([w.lon for w in where]),
        battery_frac=knows.batteries(ids),
        drain_per_s=np.array([knows.drain_per_s(m) for m in ids]),
        awake_drain_per_s=np.full(len(ids), ALWAYS_ON.drain_per_s(theta)),
        asleep=np.array([knows.duty(m).asleep for m in ids]),
        orderable=np.array([not p.asleep for p in profile]),
        slots=slots,
        start_s=start_s,
        outlook=knows.outlook(),
    )
