"""How the operator sees the links: per aPad the age of its last heartbeat, the frames its MAVLink
sequence numbers say were lost, signing on or off, restarts; and the aMussels' status stream.

Ages are in mission time (the clock the world runs on: wall time in the field). A link is late
after `LATE_S` of silence and lost after `LOST_S`; lost links make the console's "LINK LOST"
banner. Pure: `link_health` reads the registry at a time it is given.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass
from enum import StrEnum

from gcs.link.registry import VehicleRegistry
from missiontime import seconds_to_us, us_to_s

LATE_S = 1.5  # amber: a heartbeat (1 Hz) and its successor missed
LOST_S = 3.0  # red, "LINK LOST" (the aPad's own GCS failsafe holds after 3 s of our silence too)
LOSS_WINDOW_S = 10.0  # the loss rate shown is over this much of the recent past
FLEET = "aMussels"  # the name of the aMussels' status stream


class Level(StrEnum):
    OK = "ok"
    LATE = "late"
    LOST = "lost"
    WAITING = "waiting"  # never heard yet, and not for long


@dataclass(frozen=True)
class LinkHealth:
    name: str  # "aPad 1", or FLEET
    heard: bool
    age_s: float  # since it was last heard (never heard: since the console began listening)
    loss_pct: float | None = None  # frames lost over the last LOSS_WINDOW_S; None: unknown
    signing: bool | None = None  # None: not a MAVLink link of ours (the fleet stream)
    restarts: int = 0
    restarted_s: float = 0.0  # mission time of the last restart
    held_before_restart: tuple[int, ...] = ()  # what its slots held just before it

    @property
    def level(self) -> Level:
        if not self.heard:
            return Level.WAITING if self.age_s <= LOST_S else Level.LOST
        return Level.OK if self.age_s <= LATE_S else Level.LATE if self.age_s <= LOST_S else Level.LOST


class LossWindow:
    """Each aPad's (frames, lost) counters, sampled once a second; the loss over the last window."""

    def __init__(self, window_s: float = LOSS_WINDOW_S) -> None:
        self._window_us = seconds_to_us(window_s)
        self._samples: dict[int, deque[tuple[int, int, int]]] = {}

    def loss_pct(self, sysid: int, now_us: int, frames: int, lost: int) -> float | None:
        samples = self._samples.setdefault(sysid, deque())
        if not samples or now_us - samples[-1][0] >= 1_000_000:
            samples.append((now_us, frames, lost))
        while len(samples) > 1 and now_us - samples[1][0] >= self._window_us:
            samples.popleft()
        _, frames0, lost0 = samples[0]
        taken, missing = frames - frames0, lost - lost0
        return None if taken + missing <= 0 else 100.0 * missing / (taken + missing)


def link_health(
    registry: VehicleRegistry, apad_ids: Sequence[int], now_us: int, listening_since_us: int, signing: bool,
    window: LossWindow,
) -> tuple[LinkHealth, ...]:
    """Every aPad's link, then the aMussels' status stream, at mission time `now_us`."""
    out = []
    for sysid in apad_ids:
        view = registry.vehicles.get(sysid)
        if view is None:
            out.append(LinkHealth(f"aPad {sysid}", False, us_to_s(now_us - listening_since_us), signing=signing))
            continue
        out.append(LinkHealth(
            f"aPad {sysid}", True, us_to_s(now_us - view.last_heartbeat_us),
            window.loss_pct(sysid, now_us, view.frames, view.frames_lost), signing, view.restarts,
            us_to_s(view.restarted_us), view.held_before_restart,
        ))
    heard = registry.fleet_heard_us >= 0
    out.append(LinkHealth(FLEET, heard, us_to_s(now_us - (registry.fleet_heard_us if heard else listening_since_us))))
    return tuple(out)


def banner(health: Sequence[LinkHealth]) -> str:
    """The words of the LINK LOST banner; "" when no link is lost."""
    lost = [h for h in health if h.level == Level.LOST]
    if not lost:
        return ""
    return "LINK LOST: " + ", ".join(
        f"{h.name} silent {h.age_s:.1f} s" if h.heard else f"{h.name} never heard" for h in lost)
