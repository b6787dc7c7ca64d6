"""A called-up aMussel whose docking failed: seen back on its position, fetched again, or reported.

A latch that opens while closing lets its aMussel go where it was put, which is where it floated, or,
in the simulated fleet, where the aPad was last heard. The collection sends it down (`ApadActions.sink`);
then `after_failed_docking` measures where it goes down (it sinks straight) against its position.
Within `HOME_TOLERANCE_M` it is back where it works. Farther, the collection fetches it once more while
the aPad is there: called up where it settled once on the seabed, docked, and put back on its position by the
redeployment, like any other. If that cannot be done (fetched once already, too late in the mission,
depleted, another aPad's now), it is reported with its metres and the reason, which the run's
whereabouts repeat. Each outcome is a `failed_docking` event and a count in
`LoopStatus.failed_dockings` (result.json `happened`).
"""

from __future__ import annotations

from gcs.loop.crew import Crew
from gcs.results.accounting import HOME_TOLERANCE_M
from mussel_sim.geo import pair_distance_m
from mussel_sim.vocabulary import MusselState

ON_POSITION = "back on its position"
FETCHED_AGAIN = "fetched again"
OFF_POSITION = "left off its position"
SETTLED = (MusselState.ACTIVE, MusselState.DEPLETED)


def after_failed_docking(crew: Crew, mussel_id: int, fetched: set[int]) -> bool:
    """After a failed docking and its sink: whether the collection should fetch `mussel_id` again now
    (`fetched`: those it fetched again already, at most once each)."""
    knows, status = crew.knows, crew.status
    failed_s = knows.clock.time()
    knows.note_home(mussel_id)  # one with no position known (a real one first heard up there): here
    # It goes down where it is: where it will settle is known as it starts to sink.
    there, home = knows.api.get_location(mussel_id), knows.homes[mussel_id]
    off_m = pair_distance_m(there.lat, there.lon, home.lat, home.lon)
    why = None
    if off_m <= HOME_TOLERANCE_M:
        outcome = ON_POSITION
    else:
        # A call-up needs it on the seabed: it sinks for the fleet's sinking time (and may have been
        # reported docked last), bounded like a call-up.
        crew.act.wait_until(lambda: knows.state(mussel_id) in SETTLED, crew.settings.surfacing_timeout_s,
                            interruptible=False)
        why = _cannot_fetch(crew, mussel_id, fetched)
        outcome = FETCHED_AGAIN if why is None else OFF_POSITION
    status.failed_dockings[outcome] = status.failed_dockings.get(outcome, 0) + 1
    crew.log("failed_docking", mussel=mussel_id, outcome=outcome, off_m=round(off_m, 2),
             **({"why": why} if why is not None else {}))
    if outcome == ON_POSITION:
        status.off_position.pop(mussel_id, None)
        return False
    # Said beside it if it ends off its position: also when the fetch it is due does not come to pass.
    status.off_position[mussel_id] = f"docking failed at {failed_s:.0f} s, {why or 'fetched again'}"
    if why is not None:
        return False
    fetched.add(mussel_id)
    return True


def _cannot_fetch(crew: Crew, mussel_id: int, fetched: set[int]) -> str | None:
    """Why an aMussel off its position cannot be fetched again now; None if it can."""
    knows = crew.knows
    if mussel_id in fetched:
        return "and again when fetched to be put back"
    state = knows.state(mussel_id)
    if state != MusselState.ACTIVE:
        return "then depleted where it settled" if state in SETTLED else f"then {state.name.lower()}, not settled"
    if knows.too_late_to_call_up():
        return "too close to the mission end to fetch it again"
    if not knows.serves(mussel_id):
        return "another aPad's since the fleet was re-shared"
    return None
