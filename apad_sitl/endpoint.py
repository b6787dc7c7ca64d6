"""The SITL aPad as a MAVLink vehicle: one system on one transport, driven by the scheduler.

`SitlVehicle` is the core: the aPad's state (`ApadState`: hull, primitive, mode, arming, speed
override, params), the codec and transport, the physics task, the poll loop and the dispatch of each
decoded message to the handler a part registered for it. The parts, one capability each, like
MAVSDK's plugins on one `System`:

    commands.py          COMMAND_LONG / COMMAND_INT, retransmissions, COMMAND_ACK; the MAV_CMD table
    streams.py           telemetry streams, SET_MESSAGE_INTERVAL, REQUEST_MESSAGE, on-change status;
                         by exception on the ideal link (`ideal_link`, by_exception.py)
    modes.py             HOLD / GUIDED, arming, the GCS heartbeat failsafe
    navigation.py        Go To Point (DO_REPOSITION, DO_CHANGE_SPEED)
    docking.py           the aMussel fix table, Dock and Undock
    param_server.py      the PARAM protocol (and MAVLink FTP, NAKed)
    mission_protocol.py  an empty mission list
    modem_serial.py      the aPad's own nanomodem over APAD_MODEM_SERIAL (when it has one)
    status_intake.py     the fleet's AMUSSEL_STATUS frames in one batch, into the fix table

A part never sees this class: it is built with the `PartHost` this class is (`host.py`: receive,
send, log, count, the time), the `ApadState`, the command table if it answers commands, and the
plain values it needs. Parts do not call each other: what follows a change of the state is wired
here, as listeners of the state, in an order the .tlogs record (`_wire`).

Nothing received may end the vehicle: a message that fails validation is dropped and counted by
reason in `dropped` ("invalid:COMMAND_INT:x"), and an exception a handler still raises is caught
at the dispatch, counted ("handler_error:PARAM_SET") and logged as an event.

It never reads a clock: tasks receive `now_us` and the vehicle keeps the latest for handling
messages between tasks. Lat/lon <-> metres goes through `LocalFrame` around home.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from acoustic.nanomodem.ports import BytePort
from apad_sitl import messages as msgs
from apad_sitl.command_handler import CommandTable
from apad_sitl.dege7 import DegE7
from apad_sitl.docking import Docking, MusselFixTable
from apad_sitl.energy import EnergyMeter
from apad_sitl.energy_counters import EnergyCounters
from apad_sitl.geofence import Geofence
from apad_sitl.host import MessageHandler, invalid_reason, unsupported_reason
from apad_sitl.logs import VehicleLog
from apad_sitl.mission_protocol import MissionProtocol
from apad_sitl.modem_serial import ModemSerial
from apad_sitl.modes import Modes, mode_name
from apad_sitl.navigation import Navigation
from apad_sitl.param_server import ParamServer
from apad_sitl.params import ApadParams, with_param
from apad_sitl.parking import PhysicsTicks
from apad_sitl.primitives import PrimitiveState
from apad_sitl.state import ApadState
from apad_sitl.status_intake import take_statuses
from apad_sitl.streams import DEFAULT_RATES_HZ, Streams
from apad_sitl.vehicle import VehicleState
from mavlink_dialect import Codec, Transport, mavlink, signing
from mavlink_dialect.transport import Bell, ring_on
from missiontime import Scheduler
from mussel_sim.geo import LocalFrame

__all__ = ["DEFAULT_RATES_HZ", "PHYSICS_HZ", "Geofence", "MusselFixTable", "SitlVehicle"]

PHYSICS_HZ = 10.0


class SitlVehicle:
    """A simulated aPad speaking MAVLink on `transport`. Call `attach(scheduler)` to run it."""

    def __init__(
        self,
        transport: Transport,
        params: ApadParams,
        home_lat_deg: float,
        home_lon_deg: float,
        system_id: int = 1,
        current_mps: tuple[float, float] = (0.0, 0.0),
        log_dir: str | Path | None = None,
        component_id: int = mavlink.MAV_COMP_ID_AUTOPILOT1,
        rates_hz: Mapping[int, float] | None = None,
        physics_hz: float = PHYSICS_HZ,
        log_epoch_us: int = 0,
        signing_key: bytes | None = None,
        geofence_deg: Sequence[tuple[float, float]] | None = None,
        log_append: bool = False,
        modem: tuple[BytePort, Callable[[], None] | None] | None = None,
        park_at_rest: bool = True,
        ideal_link: bool = False,
    ) -> None:
        """`rates_hz` overrides DEFAULT_RATES_HZ per message id; `log_epoch_us` offsets .tlog stamps and
        is the Unix time of t = 0 for signing timestamps. With `signing_key` every frame we send is
        signed and so must be everything received, the swarm's AMUSSEL_STATUS too. `geofence_deg`
        is the water area as a (lat, lon) ring: Go To targets outside it and undocking outside it are refused.
        `modem`: the aPad's own nanomodem, its serial port and what puts it where the aPad is before
        each write (`modem_serial.py`); None: the aPad has none. `park_at_rest` False ticks the physics
        at its rate throughout (`apad_sitl.parking`: the same result, at a cost). `ideal_link`: the event
        platform's link, which carries no heartbeats and wants no repeats: telemetry by exception, and
        nothing runs while the hull rests (`apad_sitl.streams`); lockstep's default sends every period.
        """
        self.transport = transport
        self.system_id = system_id
        self.component_id = component_id
        self.codec = Codec(system_id, component_id)
        if signing_key is not None:
            self.codec.enable_signing(  # everything signed, the swarm's AMUSSEL_STATUS too (issue 10)
                signing_key, link_id=0, ticks=lambda: signing.timestamp_ticks(log_epoch_us, self.now_us))
        self.frame = LocalFrame(home_lat_deg, home_lon_deg)
        self.geofence = Geofence.of(geofence_deg, self.frame) if geofence_deg else None
        self.home_lat_deg, self.home_lon_deg = home_lat_deg, home_lon_deg
        self.physics_hz = physics_hz
        self.park_at_rest = park_at_rest
        self.ideal_link = ideal_link

        # The aPad's state (what a checkpoint saves); the parts change it.
        self.apad = ApadState(with_param(params, "SYSID_THISMAV", system_id), current_mps)
        self.now_us = 0
        self.closed = False
        self.dropped: Counter[str] = Counter()  # received messages dropped, by reason

        self._scheduler: Scheduler | None = None
        self.physics: PhysicsTicks | None = None  # the physics task, parked while the hull rests
        self._handlers: dict[int, MessageHandler] = {}
        self.log: VehicleLog | None = None

        # The parts, each built with what it uses; each registers its message and command handlers.
        apad = self.apad
        self.mussels = MusselFixTable(self.frame, self.dropped)
        target_e7 = DegE7(self.frame)  # the target a Go To commanded, echoed by PRIMITIVE_STATUS
        self.commands = CommandTable(self, apad)
        self.streams = Streams(self, apad, self.commands, self.frame, system_id, rates_hz, target_e7,
                               by_exception=ideal_link)
        self.modes = Modes(self, apad, self.commands)
        self.navigation = Navigation(self, apad, self.commands, self.frame, self.geofence, target_e7)
        self.energy = EnergyMeter(apad, self.dropped)
        self.docking = Docking(self, apad, self.commands, self.mussels, self.geofence, self.energy.heard)
        self.param_server = ParamServer(self, apad)
        self.mission_protocol = MissionProtocol(self)
        self.modem = ModemSerial(self, *modem) if modem is not None else None
        self._wire()

        if log_dir is not None:
            self.log = VehicleLog(Path(log_dir), system_id, log_epoch_us, append=log_append, tlog=not ideal_link)
        # Logged at attach, stamped with the mission time then (a resumed mission's aPad starts late).
        self._start_fields = {"system_id": system_id, "home_lat_deg": home_lat_deg, "home_lon_deg": home_lon_deg,
                              "current_mps": list(current_mps)}

    def _wire(self) -> None:
        """What follows a change of the aPad's state, in this order: the event log, then the slots'
        bookkeeping, then the telemetry that announces it."""
        apad = self.apad
        apad.on_primitive(self._log_primitive)
        apad.on_primitive(self.docking.slots_changed)  # "slot" events; a failed dock's warning
        apad.on_primitive(self.streams.primitive_changed)  # PRIMITIVE_STATUS, DOCK_SLOT_STATUS at once
        apad.on_mode(lambda mode: self.event("mode", mode=mode_name(mode)))
        apad.on_mode(lambda mode: self.streams.send_heartbeat())  # consoles show the new mode now
        apad.on_armed(lambda armed: self.event("arm" if armed else "disarm"))
        apad.on_armed(lambda armed: self.streams.send_heartbeat())

    def _log_primitive(self, old: PrimitiveState, new: PrimitiveState) -> None:
        if (new.kind, new.progress) != (old.kind, old.progress) or new.slot != old.slot:
            self.event("primitive", primitive=new.kind.name, progress=new.progress.name,
                       slot=new.slot, mussel_id=new.mussel_id,
                       target_x_m=round(new.target_x_m, 3), target_y_m=round(new.target_y_m, 3))

    # ------------------------------------------------------------------ lifecycle

    def attach(self, scheduler: Scheduler, start_us: int = 0) -> None:
        """Register the physics task, one task per telemetry stream, and this vehicle as a poller.

        `start_us` is the mission time now (tasks first fire then; a late attach does not replay).
        """
        if self._scheduler is not None:
            raise RuntimeError("vehicle already attached to a scheduler")
        self._scheduler = scheduler
        self.now_us = max(self.now_us, start_us)
        self.event("start", **self._start_fields)
        name = f"apad{self.system_id}"
        self.physics = physics = PhysicsTicks(self, scheduler, self.physics_hz, f"{name}.physics", start_us,
                                              self.park_at_rest, closed_forms=self.ideal_link)
        if self.ideal_link:  # the streams park with the physics, and wake with it
            physics.on_rearm = self.streams.wake
            self.apad.changed_while_parked = physics.settle  # ticking again if the change ended the rest
        self.streams.attach(scheduler, start_us, name, physics if self.ideal_link else None)
        if self.modem is not None:
            self.modem.attach(scheduler, start_us, name)
        self.modes.attach(scheduler, start_us, name, parked=self.ideal_link)
        scheduler.add_poller(self)

    def close(self) -> None:
        """Stop the tasks, flush and close the logs, close the transport. Idempotent."""
        if self.closed:
            return
        self.closed = True
        if self.physics is not None:
            self.physics.stop()
        self.streams.stop()
        if self.modem is not None:
            self.modem.close()
        if self._scheduler is not None:
            self._scheduler.remove_poller(self)
        self.event("close", distance_travelled_m=round(self.state.distance_travelled_m, 3),
                   battery_v=round(self.state.battery_v, 4))
        if self.log is not None:
            self.log.close()
        self.transport.close()

    def __enter__(self) -> SitlVehicle:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ state for embedders and tests

    @property
    def params(self) -> ApadParams:
        return self.apad.params

    @params.setter
    def params(self, value: ApadParams) -> None:
        self.apad.params = value

    @property
    def state(self) -> VehicleState:
        return self.apad.state

    @state.setter
    def state(self, value: VehicleState) -> None:
        self.apad.state = value

    @property
    def current_mps(self) -> tuple[float, float]:
        """The water current (east, north) m/s the hull drifts in."""
        return self.apad.current_mps

    @current_mps.setter
    def current_mps(self, value: tuple[float, float]) -> None:
        self.apad.current_mps = value

    @property
    def primitive(self) -> PrimitiveState:
        """The running primitive and the slots; `set_primitive` changes it."""
        return self.apad.primitive

    def set_primitive(self, new: PrimitiveState) -> None:
        """Swap in a new primitive state; logged and announced (on-change telemetry) by the listeners."""
        self.apad.set_primitive(new)

    @property
    def mode(self) -> int:
        """Read-only: the parts change it with `ApadState.set_mode`, a checkpoint with `ApadState.restore`."""
        return self.apad.mode

    @property
    def armed(self) -> bool:
        """Read-only: the parts change it with `ApadState.set_armed`, a checkpoint with `ApadState.restore`."""
        return self.apad.armed

    @property
    def speed_override_mps(self) -> float:
        """DO_CHANGE_SPEED for later Go Tos; 0: SPEED_MAX."""
        return self.apad.speed_override_mps

    @property
    def energy_counters(self) -> EnergyCounters:
        """Energy passed to aMussels and taken at home."""
        return self.apad.energy

    @property
    def position_deg(self) -> tuple[float, float]:
        """(lat_deg, lon_deg) of the aPad now."""
        lat_e7, lon_e7 = self.streams.position_e7.of(self.state.x_m, self.state.y_m)
        return lat_e7 / 1e7, lon_e7 / 1e7

    def gcs_link_lost(self) -> bool:
        """True if a GCS was heard and has been silent for FS_GCS_TIMEOUT."""
        self.apad.settle()  # the vehicle's time (see `send`)
        return self.modes.gcs_link_lost()

    @property
    def failsafe_active(self) -> bool:
        self.apad.settle()  # Modes' flag, which the failsafe check of a skipped tick resets
        return self.modes.failsafe_active

    @property
    def last_gcs_heartbeat_us(self) -> int | None:
        """Mission time of the last GCS HEARTBEAT; None if no GCS was ever heard."""
        return self.modes.last_gcs_heartbeat_us

    # ------------------------------------------------------------------ poller and dispatch

    def fileno(self) -> int | None:
        return None if self.closed else self.transport.fileno()

    def ring_on(self, bell: Bell) -> bool:
        """The scheduler's doorbell (`missiontime.Doorbell`): rung by the transport if it can."""
        return ring_on(self.transport, bell)

    def on(self, msg_id: int, handler: MessageHandler) -> None:
        """Route every received message `msg_id` to `handler` (one handler per message id)."""
        if msg_id in self._handlers:
            raise ValueError(f"message id {msg_id} already has a handler")
        self._handlers[msg_id] = handler

    def poll(self) -> bool:
        """Read the transport and handle every message; True if anything arrived. Never raises for
        what arrived: see `dropped`."""
        if self.closed:
            return False
        datagrams = self.transport.receive()
        if not datagrams:
            return False
        physics = self.physics
        if physics is not None:
            physics.catch_up()  # the ticks until now taken (and their time, which the handlers stamp)
        # The batch path takes unsigned frames: with signing on, everything goes through the codec's check.
        bulk = self.transport.datagrams and not self.codec.signing
        for data in self._bulk_statuses(datagrams) if bulk else datagrams:
            try:
                decoded = self.codec.decode(data)
            except Exception as exc:  # the codec promises not to; a promise is not a proof
                self._handler_error("decode", exc)
                continue
            for msg in decoded:
                if self.log is not None:
                    self.log.message(self.now_us, msg.get_msgbuf())
                handler = self._handlers.get(msg.get_msgId())
                if handler is None:
                    continue
                try:
                    handler(msg)
                except Exception as exc:  # a bug in a handler drops its message, never the vehicle
                    self._handler_error(msg.get_type(), exc)
        if physics is not None:
            physics.settle()  # ticking again if what arrived ended the rest (a command, a parameter)
        return bool(datagrams)

    def _bulk_statuses(self, datagrams: list[bytes]) -> list[bytes]:
        """The fleet's AMUSSEL_STATUS frames in one batch (`status_intake`); every other frame for the codec."""
        try:
            return take_statuses(datagrams, self.codec.stats, self.mussels, self.energy, self.log, self.now_us)
        except Exception as exc:  # the batch path promises not to raise; a promise is not a proof
            self._handler_error("AMUSSEL_STATUS batch", exc)
            return []

    def _handler_error(self, message: str, exc: Exception) -> None:
        self.dropped[f"handler_error:{message}"] += 1
        self.event("handler_error", message=message, error=f"{type(exc).__name__}: {exc}"[:200])

    def for_us(self, target_system: int, target_component: int) -> bool:
        return target_system in (0, self.system_id) and target_component in (0, self.component_id)

    def count_invalid(self, message: str, field: str) -> None:
        """Count a received `message` dropped (or refused) because `field` holds no legal value."""
        self.dropped[invalid_reason(message, field)] += 1

    def count_unsupported(self, message: str) -> None:
        """Count a received `message` that asks for something the aPad does not do."""
        self.dropped[unsupported_reason(message)] += 1

    # ------------------------------------------------------------------ what the parts share

    def send(self, msg: mavlink.MAVLink_message) -> None:
        # The vehicle's time, `now_us`, is the one thing the parked ticks advance that is not the
        # aPad's state (ApadState settles for the rest): what is stamped (and signed) with it settles here.
        self.apad.settle()
        frame = self.codec.encode(msg)
        self.transport.send(frame)
        if self.log is not None:
            self.log.message(self.now_us, frame)

    def statustext(self, severity: int, text: str) -> None:
        self.send(msgs.statustext(severity, text))

    def event(self, event: str, /, **fields: Any) -> None:
        if self.log is not None:
            self.apad.settle()  # stamped with the vehicle's time (see `send`)
            self.log.event(self.now_us, event, **fields)
