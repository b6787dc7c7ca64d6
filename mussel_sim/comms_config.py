"""The fleet's MAVLink node: its ids, its step and publish rates, whom it obeys (`mussel_sim.comms`)."""

from __future__ import annotations

from dataclasses import dataclass

FLEET_SYSTEM_ID = 251
FLEET_COMPONENT_ID = 25
SURFACE_DEPTH_M = 0.01  # this shallow an aMussel is at the surface, in WiFi's reach (floating and docked: 0 m)
HEARTBEAT_PERIOD_S = 1.0
MODEL_STEP_S = 1.0  # the model steps at 1 Hz of mission time (the paper's ROS node)


class MusselIdCollision(RuntimeError):
    """A real aMussel reported an id this fleet simulates: the run cannot tell them apart."""

    def __init__(self, mussel_id: int, source_system: int) -> None:
        super().__init__(
            f"aMussel id {mussel_id} is simulated by this fleet and also reported by a real aMussel "
            f"(MAVLink system {source_system}); give the simulated fleet ids that no real node uses"
        )
        self.mussel_id = mussel_id
        self.source_system = source_system


@dataclass(frozen=True)
class CommsConfig:
    step_period_s: float = MODEL_STEP_S
    status_rate_hz: float = 1.0  # AMUSSEL_STATUS per aMussel
    sensors_rate_hz: float = 0.2  # AMUSSEL_SENSORS per aMussel
    # An aMussel whose state has not changed reports only this often (`report_policy`); 0: every publish.
    status_keepalive_s: float = 0.0
    apad_ids: frozenset[int] | None = None  # systems whose positions and slots are an aPad's; None: any
    commanders: frozenset[int] | None = None  # systems whose AMUSSEL_COMMAND is obeyed (a GCS); None: any
    report_refusals: bool = True  # STATUSTEXT for surface commands refused for safety
    # Acoustic scenarios: only aMussels at the surface speak over MAVLink (WiFi); the others are heard
    # through their TDMA slots (`mussel_sim.modems`) or, depleted under water, not at all. False: every
    # aMussel over MAVLink, as in the paper's WiFi-only experiment.
    wifi_at_surface_only: bool = False
