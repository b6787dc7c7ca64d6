"""Mission time and the one scheduler that drives the world (lockstep or wall clock)."""

from missiontime.clocks import (
    MAX_DRAIN_ROUNDS,
    US_PER_S,
    Clock,
    Doorbell,
    PacedClock,
    Poller,
    Scheduler,
    Task,
    VirtualClock,
    WallClock,
    mm_ss,
    seconds_to_us,
    unix_time_us,
    us_to_s,
)

__all__ = [
    "MAX_DRAIN_ROUNDS",
    "US_PER_S",
    "Clock",
    "Doorbell",
    "PacedClock",
    "Poller",
    "Scheduler",
    "Task",
    "VirtualClock",
    "WallClock",
    "mm_ss",
    "seconds_to_us",
    "unix_time_us",
    "us_to_s",
]
