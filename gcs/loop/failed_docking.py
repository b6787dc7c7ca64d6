"""A called-up aMussel whose docking failed: docked at a second try, seen back on its position,
fetched again, or reported.

One still floating beside the aPad (the dock command lost on the way, all its sends; a refusal) is
docked once more at once (`dock_again`), closing in first. A latch that opens while closing lets its
aMussel go where it was put, which is where it floated, or, in the simulated fleet, where the aPad
was last heard: the collection sends it down (`ApadActions.sink`), and `after_failed_docking`
measures where it goes down (it sinks straight) against its position. Within `HOME_TOLERANCE_M` it
is back where it works. Farther, the collection fetches it once more while the aPad is there:
called up where it settled once on the seabed, docked, and put back on its position by the
redeployment like any other. If that cannot be done (fetched once already, too late in the mission,
depleted, another aPad's now), it is reported with its metres and the reason, which the run's
whereabouts repeat. Each failure's last outcome is a `failed_docking` event and a count in
`LoopStatus.failed_dockings` (result.json `happened`).
"""

from __future__ import annotations

from gcs.loop.crew import Crew
from gcs.results.accounting import HOME_TOLERANCE_M
from mussel_sim.geo import pair_distance_m
from mussel_sim.vocabulary import MusselState

DOCKED_AGAIN = "docked at the second try"
ON_POSITION = "back on its position"
FETCHED_AGAIN = "fetched again"
OFF_POSITION = "left off its position"
AT_SURFACE = "left at the surface"  # the sink went unanswered: floating, unclaimed (an orphan to fetch)
SETTLED = (MusselState.ACTIVE, MusselState.DEPLETED)


def dock_again(crew: Crew, slot: int, mussel_id: int) -> bool:
    """A docking that failed with the aMussel still floating beside the aPad (the command lost on the
    way, every send of it; a refusal): close in and dock once more while the aPad is there."""
    knows, act = crew.knows, crew.act
    if knows.state(mussel_id) != MusselState.FLOATING or slot not in knows.free_slots() or knows.taken_over(mussel_id):
        return False  # gone down (a latch that reopened lets it sink), or no longer this aPad's
    if knows.distance_to(mussel_id) > 0.8 * crew.settings.dock_reach_m:
        act.go_to(knows.location(mussel_id), interruptible=False)
    if not act.dock(slot, mussel_id):
        return False  # sent down: `after_failed_docking` says where
    _count(crew, DOCKED_AGAIN)
    crew.log("failed_docking", mussel=mussel_id, outcome=DOCKED_AGAIN)
    return True


def after_failed_docking(crew: Crew, mussel_id: int, fetched: set[int]) -> bool:
    """After a failed docking and its sink: whether the collection should fetch `mussel_id` again now
    (`fetched`: those it fetched again already, at most once each)."""
    knows, status = crew.knows, crew.status
    failed_s = knows.clock.time()
    crew.book.note_home(mussel_id)  # one with no position known (a real one first heard up there): here
    # It goes down where it is: where it will settle is known as it starts to sink.
    there, home = knows.location(mussel_id), knows.homes[mussel_id]
    off_m = pair_distance_m(there.lat, there.lon, home.lat, home.lon)
    why = None
    if knows.state(mussel_id) in (MusselState.FLOATING, MusselState.SURFACING):  # the sink went unanswered
        why = "it did not answer the sink command"
        outcome = AT_SURFACE
    elif off_m <= HOME_TOLERANCE_M:
        outcome = ON_POSITION
    else:
        # A call-up needs it on the seabed: it sinks for the fleet's sinking time (and may have been
        # reported docked last), bounded like a call-up.
        crew.act.wait_until(lambda: knows.state(mussel_id) in SETTLED, crew.settings.surfacing_timeout_s,
                            interruptible=False)
        why = _cannot_fetch(crew, mussel_id, fetched)
        outcome = FETCHED_AGAIN if why is None else OFF_POSITION
    _count(crew, outcome)
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


def _count(crew: Crew, outcome: str) -> None:
    counts = crew.status.failed_dockings
    counts[outcome] = counts.get(outcome, 0) + 1
