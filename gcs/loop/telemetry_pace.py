"""The telemetry a mission asks its aPad for, paced by what the aPad is doing.

A bandwidth-conscious GCS on a real link asks for what it needs: fast position and primitive
reports while the aPad moves, slow ones while it holds in place waiting (for the pool to fill, for
its aMussels to charge, at its home charger). Asked the standard way, SET_MESSAGE_INTERVAL, which
any MAVLink vehicle honours; changes of slot and primitive are still sent the moment they happen,
so nothing the loop waits for comes later. In lockstep the holding aPad then also costs less: its
hull rests (`apad_sitl.rest`) and its reports are few.

A request the aPad does not answer (a lossy or silent link) keeps the rate it had: logged as a
`telemetry_rate_failed` event, retried at the next change, never fatal, and bounded by
`PACE_RETRIES` so a silent link does not hold the loop up.
"""

from __future__ import annotations

from gcs.link.apad_api import ApadApi
from gcs.loop.control import LoopLog, Phase
from mavlink_dialect import mavlink

# What the mission loop needs from the aPad while it moves. Slot and primitive changes are also sent
# the moment they happen, so slow periodic copies do. The battery comes in SYS_STATUS, and a boat's
# pack drains over hours: 0.2 Hz is plenty for the end-of-mission check. BATTERY_STATUS says whether
# it charges at home.
MISSION_TELEMETRY_HZ = {
    mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 2.0,
    mavlink.MAVLINK_MSG_ID_PRIMITIVE_STATUS: 1.0,
    mavlink.MAVLINK_MSG_ID_DOCK_SLOT_STATUS: 0.2,
    mavlink.MAVLINK_MSG_ID_SYS_STATUS: 0.2,
    mavlink.MAVLINK_MSG_ID_BATTERY_STATUS: 0.2,  # charge_state: whether it charges at home
}
# While it holds in place: a position every 5 s (it does not move), the primitive as often (its
# changes come at once anyway). 0.2 Hz: a 10th of the moving rate, and the fast rate's phase is kept
# by the aPad when it speeds up again (`apad_sitl.streams`), so what the loop sees while moving
# does not depend on how long it waited before.
HOLDING_TELEMETRY_HZ = {
    mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 0.2,
    mavlink.MAVLINK_MSG_ID_PRIMITIVE_STATUS: 0.2,
}
MOVING_TELEMETRY_HZ = {msg_id: MISSION_TELEMETRY_HZ[msg_id] for msg_id in HOLDING_TELEMETRY_HZ}
# The loop's phases in which the aPad holds where it is.
HOLDING_PHASES = frozenset({Phase.IDLE_WAIT, Phase.CHARGING_WAIT})
# Phases that only think (no command, no mission time): the pace stays as it was. A plan that takes
# nobody leaves the aPad holding; the phase that acts on a plan asks for fast telemetry itself.
PLANNING_PHASES = frozenset({Phase.PLAN_COLLECT, Phase.PLAN_REDEPLOY})
PACE_RETRIES = 1  # one resend (1 s, then 1.5 s): a silent link costs the loop at most 2.5 s per message
# A wait in a phase that acts (above a called-up aMussel) is paced slow only if it is expected to last
# longer than this: two rounds of requests (slow, then fast again) are not worth a short wait, and on a
# lossy link each may cost the loop seconds (PACE_RETRIES).
PACE_WORTH_S = 60.0


class TelemetryPace:
    """One aPad's telemetry rates by activity; it starts as the world asked, moving. The loop's actions
    call `hold` when a wait in a holding phase begins (not at once: an idle wait the pool already
    satisfies asks nothing) and `move` when a phase that acts begins.

    Each message's rate is believed in force only once the aPad acknowledged it: a request that went
    unanswered (its ACK or itself lost) leaves that message unknown, asked again at the next `hold` or
    `move`. One granted and one not is not a change made: a position left at the holding rate while
    the aPad sails is what a docking is judged by (issue 39: 20 s stale at 40 % loss)."""

    def __init__(self, api: ApadApi, apad_id: int, log: LoopLog) -> None:
        self._api = api
        self._apad_id = apad_id
        self._log = log
        self._granted: dict[int, float] = dict(MOVING_TELEMETRY_HZ)  # message id -> rate the aPad acknowledged
        self.requests = 0  # SET_MESSAGE_INTERVAL requests sent for pacing (each message id counts)

    @property
    def holding(self) -> bool:
        """Whether any message is not known to be at its moving rate (slow, or its request unanswered)."""
        return any(self._granted.get(m) != hz for m, hz in MOVING_TELEMETRY_HZ.items())

    def hold(self) -> None:
        self._ask(HOLDING_TELEMETRY_HZ)

    def move(self) -> None:
        self._ask(MOVING_TELEMETRY_HZ)

    def _ask(self, rates_hz: dict[int, float]) -> None:
        wanted = {m: hz for m, hz in rates_hz.items() if self._granted.get(m) != hz}
        if not wanted:
            return
        failed = self._api.set_telemetry_rates(wanted, self._apad_id, retries=PACE_RETRIES)
        self.requests += len(wanted)
        for msg_id, hz in wanted.items():
            exc = failed.get(msg_id)
            if exc is None:
                self._granted[msg_id] = hz
                continue
            self._granted.pop(msg_id, None)  # it may have arrived and only its ACK was lost: unknown
            known = mavlink.mavlink_map.get(msg_id)
            self._log("telemetry_rate_failed", message=known.msgname if known else msg_id, what=str(exc))
