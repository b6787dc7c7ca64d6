"""Every aMussel's believed battery at once: the scalar beliefs (`foresight`, `acoustic_net.knowledge`) as numpy
over the GCS's table, to the bit.

The loop reads the whole fleet at every look of its idle wait (the pool, the instant it could next grow) and
for a sleep schedule. The beliefs that run forward the same way for every aMussel are taken here for all rows
at once, operation for operation as the scalar ones take them, so each float is the scalar's: a simulated
aMussel deployed, run forward in the model's whole steps (`foreseen_battery`); one under water in an acoustic
scenario, run down since its report or its last sleep order (`believed_battery`); one depleted, as reported.
The rest are left to the scalar (`exact` False): a docked one, charged band by band in a loop
(`charged_forward`), and a real one's estimate; a few at a time.

Pure: the caller passes the table's columns, the instant and each row's drain and anchor.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from gcs.acoustic_net.knowledge import UNDERWATER
from gcs.belief.foresight import MODEL_STEP_US
from missiontime import US_PER_S
from mussel_sim.comms import MODEL_STEP_S
from mussel_sim.vocabulary import MusselState

NO_ANCHOR_US = np.iinfo(np.int64).min  # before every report: the run-down starts at the report


@dataclass(frozen=True)
class Believed:
    """Some aMussels as a loop believes them at one instant, lowest id first; arrays `(n,)`."""

    ids: NDArray[np.int64]
    battery: NDArray[np.float64]  # `FleetKnowledge.battery` of each, to the bit
    drain_per_s: NDArray[np.float64]  # deployed, by its duty (`FleetKnowledge.drain_per_s`)
    heard_us: NDArray[np.int64]  # when its last report was made (mission us)
    simulated: NDArray[np.bool_]


@dataclass(frozen=True)
class Anchors:
    """Per table row, what was believed when a sleep order last changed its duty (`OrdersSent.changed`):
    mission us (`NO_ANCHOR_US`: never) and battery."""

    us: NDArray[np.int64]
    frac: NDArray[np.float64]

    @staticmethod
    def of(ids: Iterable[int], changed: Mapping[int, tuple[int, float]]) -> Anchors:
        """The anchors of the table's rows `ids`, from the loop's orders."""
        pairs = [changed.get(m, (NO_ANCHOR_US, 0.0)) for m in ids]
        return Anchors(np.array([us for us, _ in pairs], np.int64), np.array([frac for _, frac in pairs], np.float64))


def _lookup(states: Iterable[MusselState]) -> NDArray[np.bool_]:
    wanted = np.zeros(256, bool)
    wanted[[int(s) for s in states]] = True
    return wanted


_UNDERWATER = _lookup(UNDERWATER)
_OWN_WAY = _lookup((MusselState.DOCKED, MusselState.DEPLETED))  # not run forward as deployed


def believed_rows(battery_frac: NDArray[np.float64], time_us: NDArray[np.int64], state: NDArray[np.integer],
                  simulated: NDArray[np.bool_], now_us: int, drain_per_s: NDArray[np.float64],
                  anchors: Anchors, acoustic: bool) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """(belief, exact) per table row at `now_us`: where `exact`, the battery `FleetKnowledge.battery` gives, to
    the bit; elsewhere (a docked or a real aMussel) the report's, for the scalar to replace. `anchors`: the
    loop's sleep orders (a run-down starts at one later than the report); `acoustic`: an aMussel under water
    is heard now and then (run down by the second), else every simulated one is run forward in model steps."""
    belief = battery_frac.copy()
    own_way = _OWN_WAY[state]
    exact = simulated & ~(state == MusselState.DOCKED)
    underwater = simulated & _UNDERWATER[state] if acoustic else np.zeros_like(simulated)
    stepped = simulated & ~own_way & ~underwater
    later = anchors.us > time_us
    if stepped.any():  # `foreseen_battery` of a deployed one: whole model steps, none at all within a step
        ordered = later[stepped]
        frac = np.where(ordered, anchors.frac[stepped], battery_frac[stepped])
        steps = np.where(ordered, np.maximum(now_us // MODEL_STEP_US - anchors.us[stepped] // MODEL_STEP_US, 0),
                         np.maximum(now_us - time_us[stepped], 0) // MODEL_STEP_US)
        run = np.maximum(frac - steps * drain_per_s[stepped] * MODEL_STEP_S, 0.0)
        belief[stepped] = np.where(steps == 0, frac, run)
    if underwater.any():  # `believed_battery`: from the report or a later order's anchor
        report_us = time_us[underwater]
        anchor_us = anchors.us[underwater]
        since_us = np.where(later[underwater], anchor_us, report_us)
        start = np.where(later[underwater], anchors.frac[underwater], battery_frac[underwater])
        belief[underwater] = np.maximum(
            start - drain_per_s[underwater] * np.maximum(now_us - since_us, 0) / US_PER_S, 0.0)
    return belief, exact
