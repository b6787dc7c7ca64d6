"""The PARAM protocol, GCS side: set a parameter and read back what the vehicle now holds."""

from __future__ import annotations

from gcs.link.command_protocol import AUTOPILOT, POLL_S, Send
from gcs.link.registry import VehicleRegistry
from mavlink_dialect import mavlink
from missiontime import Clock, seconds_to_us


class ParamClient:
    def __init__(self, send: Send, registry: VehicleRegistry, clock: Clock) -> None:
        self._send = send
        self._registry = registry
        self._clock = clock

    def set(
        self, system_id: int, name: str, value: float, timeout_s: float = 1.0, retries: int = 3,
        component_id: int = AUTOPILOT,
    ) -> float:
        """PARAM_SET until the vehicle answers PARAM_VALUE for `name`; return the value it now holds.

        A vehicle that refuses a value answers with the old one: that is a `ValueError` here; no
        answer after `retries + 1` attempts is a `TimeoutError`.
        """
        view = self._registry.vehicles.get(system_id)
        if view is None:
            raise LookupError(f"aPad {system_id} has not been heard")
        msg = mavlink.MAVLink_param_set_message(
            system_id, component_id, name.encode(), float(value), mavlink.MAV_PARAM_TYPE_REAL32
        )
        clock = self._clock
        for _ in range(retries + 1):
            view.params.pop(name, None)
            self._send(msg)
            deadline = clock.now_us + seconds_to_us(timeout_s)
            clock.sleep(0)
            while name not in view.params and clock.now_us < deadline:
                clock.sleep(min(POLL_S, timeout_s))
            if name in view.params:
                held = view.params[name]
                if abs(held - float(value)) > 1e-6 * max(1.0, abs(float(value))):
                    raise ValueError(f"aPad {system_id} refused {name}={value:g}; it keeps {held:g}")
                return held
        raise TimeoutError(f"aPad {system_id}: no PARAM_VALUE for {name} after {retries + 1} attempts")
