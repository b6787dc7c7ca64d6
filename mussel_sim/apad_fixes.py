"""The aPads' positions as the fleet heard them (GLOBAL_POSITION_INT), and as its step uses them.

A step looks at the aPads' positions only where an aMussel rides on one (docked, or docking now) or is
called up (a command, or one held for a sleeper's wake): then they go in the fleet's metres, converted
again only when an aPad moved. In any other step the last ones go again, unconverted. Pure bookkeeping:
the runner passes what it heard and the state.

A step at an instant uses the positions heard before it (lockstep delivers an instant's messages after
its tasks). On the event platform a step may be taken after later positions came in (an input's
catch-up to lockstep's last step instant): each is then kept with when it was heard (`hear`) and taken
by the first step after it (`for_step`'s `step_us`), so a docked aMussel is where lockstep's is.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from mussel_sim.fleet_state import FleetState
from mussel_sim.geo import LocalFrame
from mussel_sim.memo import LastMade
from mussel_sim.vocabulary import MusselState


class ApadFixes:
    """`deg`: system id -> (lat_deg, lon_deg) last heard."""

    def __init__(self, frame: LocalFrame) -> None:
        self.frame = frame
        self.deg: dict[int, tuple[float, float]] = {}
        self._later: list[tuple[int, int, tuple[float, float]]] = []  # (heard at, aPad, position) not yet used
        self._key: tuple[tuple[int, tuple[float, float]], ...] = ()
        self._m: dict[int, tuple[float, float]] = {}
        self._rides = LastMade(_rides)  # a state's arrays are read-only: asked once each

    def hear(self, system_id: int, lat_lon_deg: tuple[float, float], at_us: int | None = None) -> None:
        """An aPad's position, heard at `at_us` (None: for the next step whenever it is, lockstep's)."""
        if at_us is None:
            self.deg[system_id] = lat_lon_deg
        else:
            self._later.append((at_us, system_id, lat_lon_deg))

    def for_step(self, state: FleetState, commands_pending: bool, step_us: int | None = None
                 ) -> Mapping[int, tuple[float, float]]:
        """The aPads' positions in metres for the next step of `state` (`commands_pending`: it takes some;
        `step_us`: its instant, which takes what was heard before it); read-only (the step's inputs are made
        from it)."""
        if self._later:  # heard in time order: those before the step are the first
            due = [late for late in self._later if step_us is None or late[0] < step_us]
            self.deg.update((sid, fix) for _, sid, fix in due)
            del self._later[:len(due)]
        if not (commands_pending or self._rides(state.state, state.surface_held)):
            return self._m
        key = tuple(sorted(self.deg.items()))
        if key != self._key:
            apads = {}
            if key:
                lat = np.array([p[0] for _, p in key])
                lon = np.array([p[1] for _, p in key])
                x, y = self.frame.to_local(lat, lon)
                apads = {a: (float(x[k]), float(y[k])) for k, (a, _) in enumerate(key)}
            self._key, self._m = key, apads
        return self._m


def _rides(state: NDArray[np.uint8], surface_held: NDArray[np.bool_]) -> bool:
    """Whether an aMussel needs the aPads' positions in a step: docked, or a call-up held for its wake."""
    return bool((state == MusselState.DOCKED).any() or surface_held.any())
