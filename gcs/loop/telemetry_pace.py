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
    satisfies asks nothing) and `move` when a phase that acts begins."""

    def __init__(self, api: ApadApi, apad_id: int, log: LoopLog) -> None:
        self._api = api
        self._apad_id = apad_id
        self._log = log
        self.holding = False
        self.requests = 0  # SET_MESSAGE_INTERVAL requests sent for pacing (each message id counts)

    def hold(self) -> None:
        if not self.holding:
            self._ask(HOLDING_TELEMETRY_HZ, holding=True)

    def move(self) -> None:
        if self.holding:
            self._ask(MOVING_TELEMETRY_HZ, holding=False)

    def _ask(self, rates_hz: dict[int, float], holding: bool) -> None:
        failed = self._api.set_telemetry_rates(rates_hz, self._apad_id, retries=PACE_RETRIES)
        self.requests += len(rates_hz)
        for msg_id, exc in failed.items():
            known = mavlink.mavlink_map.get(msg_id)
            self._log("telemetry_rate_failed", message=known.msgname if known else msg_id, what=str(exc))
        # Believed changed unless every request failed: the next change asks again either way.
        if len(failed) < len(rates_hz):
            self.holding = holding
