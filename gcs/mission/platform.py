"""The platforms a headless mission runs on: one mission's code, two fidelities (docs/platforms.md).

    lockstep  the reference: a virtual clock that runs every periodic task, every MAVLink byte through a
              transport (heartbeats, telemetry streams, .tlogs), faults, signing and serial ports
    event     discrete events: time jumps to the next thing that happens, over an ideal link (lossless,
              instant, no heartbeats, reports by exception), the models stepped only when they change

Both run the same strategies, phases, knowledge, aPad, fleet, accounting and run folder; only the clock,
the link and how the models advance between events differ (`gcs.mission.world` builds either). Every
result names its platform, and `bench/platforms.py` holds the event platform to lockstep's answers.

What is about the wire has no meaning on an ideal link: asked for on the event platform it is refused
(`wire_only_problem`), in one line that says to use lockstep.
"""

from __future__ import annotations

from collections.abc import Iterable
from enum import StrEnum


class Platform(StrEnum):
    LOCKSTEP = "lockstep"
    EVENT = "event"


DEFAULT_PLATFORM = Platform.LOCKSTEP
PLATFORM_HELP = ("lockstep (default: every MAVLink byte on the wire, the reference) or event (discrete "
                 "events over an ideal link, no .tlog; 3 to 8 times as fast so far: docs/platforms.md)")


def platform_title(platform: Platform) -> str:
    """How a table's title names the platform."""
    return "lockstep SITL" if platform is Platform.LOCKSTEP else "event platform, ideal link"


def platform_of(text: str) -> Platform:
    """A platform by name; ValueError (one line naming the choices) for anything else."""
    try:
        return Platform(text)
    except ValueError:
        raise ValueError(f"unknown platform {text!r}; choose {' or '.join(p.value for p in Platform)}") from None


WIRE = "is about the wire, and the event platform's link is ideal (no bytes, no faults): use --platform lockstep"
NO_CHECKPOINT = ("is not for the event platform, which keeps no checkpoint (a run takes seconds): run it again, "
                 "or use --platform lockstep")


def wire_only_problem(platform: Platform, asked: Iterable[tuple[str, str]]) -> str | None:
    """One line refusing the first of `asked` ((option, why) for each option given that the event platform
    cannot honour: faults, signing, a proxy, a resume) on the event platform; None where nothing is refused."""
    first = next(iter(asked), None)
    if platform is not Platform.EVENT or first is None:
        return None
    option, why = first
    return f"{option} {why}"
