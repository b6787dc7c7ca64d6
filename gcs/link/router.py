"""The GCS's MAVLink link: one router between local parties and the aPads' transports.

Local parties (the GCS itself, the simulated aMussel fleet) each get a `Port`; what a port
sends goes out on every aPad transport and, parsed from the same bytes, to every other local
party. What arrives from a transport is parsed once (one parser per transport, so streams keep
their own framing) and handed to every local party. The link keeps a `VehicleView` per aPad
system id from their telemetry, sends the GCS heartbeat, runs the command protocol (ACK,
timeout, retry) and records a .tlog of everything that crossed a transport.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import BinaryIO

from apad_sitl.vocabulary import Latch, Primitive, Progress
from mavlink_dialect import Codec, Transport, mavlink
from missiontime import Clock

GCS_SYSTEM_ID = 250
GCS_COMPONENT_ID = mavlink.MAV_COMP_ID_MISSIONPLANNER
HEARTBEAT_PERIOD_S = 1.0

Handler = Callable[[mavlink.MAVLink_message], None]


class CommandError(Exception):
    """A command the vehicle refused or never acknowledged; `result` is the MAV_RESULT (None: no ACK)."""

    def __init__(self, system_id: int, command: int, result: int | None, detail: str = "") -> None:
        self.system_id, self.command, self.result = system_id, command, result
        name = mavlink.enums["MAV_CMD"][command].name if command in mavlink.enums["MAV_CMD"] else str(command)
        if result is None:
            what = "no COMMAND_ACK"
        else:
            what = mavlink.enums["MAV_RESULT"][result].name if result in mavlink.enums["MAV_RESULT"] else str(result)
        super().__init__(f"aPad {system_id}: {name} failed: {what}{f' ({detail})' if detail else ''}")


@dataclass
class SlotView:
    slot: int
    mussel_id: int = 0  # 0: empty
    latch: Latch = Latch.OPEN
    charging: bool = False


@dataclass
class PrimitiveView:
    primitive: Primitive = Primitive.IDLE
    progress: Progress = Progress.NONE
    target_lat_e7: int = 0
    target_lon_e7: int = 0
    distance_to_go_m: float = 0.0
    distance_travelled_m: float = 0.0
    slot: int = 0
    mussel_id: int = 0
    time_us: int = 0


@dataclass
class VehicleView:
    """Everything the GCS knows about one aPad, from its own telemetry."""

    system_id: int
    last_heartbeat_us: int = 0
    custom_mode: int = 0
    armed: bool = False
    lat_deg: float | None = None
    lon_deg: float | None = None
    heading_deg: float = 0.0
    battery_v: float | None = None
    battery_pct: int = -1
    home: tuple[float, float] | None = None
    primitive: PrimitiveView = field(default_factory=PrimitiveView)
    slots: dict[int, SlotView] = field(default_factory=lambda: {s: SlotView(s) for s in range(1, 5)})
    params: dict[str, float] = field(default_factory=dict)
    statustext: list[str] = field(default_factory=list)


@dataclass
class _PendingCommand:
    system_id: int
    command: int
    ack: mavlink.MAVLink_command_ack_message | None = None


class Port:
    """A local party's way onto the link: `send` bytes it encoded, `handler` gets what others sent.

    A party that still holds the message object it encoded passes it to `send_local` right
    after `send_bytes`: co-located parties then get the object instead of parsing the bytes back
    (the bytes still go out, encoded, on every transport).
    """

    def __init__(self, link: Link, handler: Handler | None) -> None:
        self.link = link
        self.handler = handler

    def send(self, data: bytes) -> None:
        """Bytes out on every transport, parsed once for the other local parties."""
        self.link._route_local(self, data)

    def send_bytes(self, data: bytes) -> None:
        """Bytes out on every transport only; follow with `send_local(msg)`."""
        for poller in self.link._pollers:
            poller.transport.send(data)

    def send_local(self, msg: mavlink.MAVLink_message) -> None:
        self.link._deliver_local(self, msg)


class _TransportPoller:
    """Reads one transport for the scheduler; one parser per transport keeps stream framing apart."""

    def __init__(self, link: Link, transport: Transport) -> None:
        self.link = link
        self.transport = transport
        self.codec = Codec(GCS_SYSTEM_ID, GCS_COMPONENT_ID)

    def poll(self) -> bool:
        chunks = self.transport.receive()
        for chunk in chunks:
            for msg in self.codec.decode(chunk):
                self.link._deliver_remote(msg)
        return bool(chunks)

    def fileno(self) -> int | None:
        return self.transport.fileno()


class Link:
    """Routes MAVLink between local parties and aPad transports; tracks vehicles; runs commands."""

    def __init__(
        self,
        clock: Clock,
        system_id: int = GCS_SYSTEM_ID,
        component_id: int = GCS_COMPONENT_ID,
        tlog_path: Path | None = None,
        tlog_epoch_us: int = 0,
        append: bool = False,
    ) -> None:
        """`append` continues an existing .tlog (a resumed mission)."""
        self.clock = clock
        self.codec = Codec(system_id, component_id)
        self._pollers: list[_TransportPoller] = []
        self._ports: list[Port] = []
        self._loopback = Codec(system_id, component_id)  # parses local parties' bytes for each other
        self.vehicles: dict[int, VehicleView] = {}
        self._pending: list[_PendingCommand] = []
        self._tlog: BinaryIO | None = tlog_path.open("ab" if append else "wb") if tlog_path else None
        self._signing: tuple[bytes, int, Callable[[], int]] | None = None
        self._tlog_epoch_us = tlog_epoch_us
        self.port = self.attach(self._handle)  # the GCS's own party
        self._heartbeat = mavlink.MAVLink_heartbeat_message(
            mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, mavlink.MAV_STATE_ACTIVE, 3
        )
        clock.scheduler.every(HEARTBEAT_PERIOD_S, self._send_heartbeat, "gcs.heartbeat", clock.now_us)

    # --- wiring -----------------------------------------------------------------------------

    def add_transport(self, transport: Transport) -> None:
        poller = _TransportPoller(self, transport)
        if self._signing is not None:
            self._verify(poller.codec)
        self._pollers.append(poller)
        self.clock.scheduler.add_poller(poller)

    @property
    def bad_data(self) -> int:
        """Frames from the aPads' transports dropped as garbage, CRC-broken or badly signed."""
        return sum(p.codec.stats.bad_data for p in self._pollers)

    def enable_signing(self, key: bytes, link_id: int, ticks: Callable[[], int]) -> None:
        """Sign every command and heartbeat; accept from the aPads only frames signed with `key`.

        `ticks` gives the MAVLink signing timestamp now (see `mavlink_dialect.signing`).
        """
        self._signing = (key, link_id, ticks)
        self.codec.enable_signing(key, link_id, ticks)
        for poller in self._pollers:
            self._verify(poller.codec)

    def _verify(self, codec: Codec) -> None:
        assert self._signing is not None
        key, link_id, ticks = self._signing
        codec.enable_signing(key, link_id, ticks)

    def attach(self, handler: Handler | None) -> Port:
        port = Port(self, handler)
        self._ports.append(port)
        return port

    def close(self) -> None:
        for poller in self._pollers:
            self.clock.scheduler.remove_poller(poller)
            poller.transport.close()
        self._pollers.clear()
        if self._tlog is not None:
            self._tlog.close()
            self._tlog = None

    # --- routing ----------------------------------------------------------------------------

    def send(self, msg: mavlink.MAVLink_message) -> None:
        """Encode `msg` as the GCS and send it to every aPad and every other local party."""
        self.port.send(self.codec.encode(msg))

    def _route_local(self, origin: Port, data: bytes) -> None:
        for poller in self._pollers:
            poller.transport.send(data)
        for msg in self._loopback.decode(data):
            self._deliver_local(origin, msg)

    def _deliver_local(self, origin: Port, msg: mavlink.MAVLink_message) -> None:
        self._record(msg)
        for port in self._ports:
            if port is not origin and port.handler is not None:
                port.handler(msg)

    def _deliver_remote(self, msg: mavlink.MAVLink_message) -> None:
        self._record(msg)
        for port in self._ports:
            if port.handler is not None:
                port.handler(msg)

    def _record(self, msg: mavlink.MAVLink_message) -> None:
        if self._tlog is not None:
            self._tlog.write(struct.pack(">Q", self._tlog_epoch_us + self.clock.now_us) + msg.get_msgbuf())

    def _send_heartbeat(self, now_us: int) -> None:
        self.send(self._heartbeat)

    # --- vehicle state ----------------------------------------------------------------------

    def _handle(self, msg: mavlink.MAVLink_message) -> None:
        kind = msg.get_type()
        sysid = msg.get_srcSystem()
        if kind == "HEARTBEAT":
            if msg.type in (mavlink.MAV_TYPE_GCS, mavlink.MAV_TYPE_ONBOARD_CONTROLLER):
                return
            view = self.vehicles.setdefault(sysid, VehicleView(sysid))
            view.last_heartbeat_us = self.clock.now_us
            view.custom_mode = msg.custom_mode
            view.armed = bool(msg.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
            return
        view = self.vehicles.get(sysid)
        if view is None:
            return  # not (yet) a known vehicle: the fleet, another GCS, or an aPad before its heartbeat
        if kind == "GLOBAL_POSITION_INT":
            view.lat_deg, view.lon_deg = msg.lat / 1e7, msg.lon / 1e7
            if msg.hdg != 65535:
                view.heading_deg = msg.hdg / 100.0
        elif kind == "PRIMITIVE_STATUS":
            view.primitive = PrimitiveView(
                Primitive(msg.primitive), Progress(msg.progress), msg.target_lat, msg.target_lon,
                msg.distance_to_go, msg.distance_travelled, msg.slot, msg.mussel_id, msg.time_us,
            )
        elif kind == "DOCK_SLOT_STATUS":
            if 1 <= msg.slot <= 4:
                view.slots[msg.slot] = SlotView(msg.slot, msg.mussel_id, Latch(msg.latch), bool(msg.charging))
        elif kind == "SYS_STATUS":
            if msg.voltage_battery != 65535:
                view.battery_v = msg.voltage_battery / 1000.0
            view.battery_pct = msg.battery_remaining
        elif kind == "HOME_POSITION":
            view.home = (msg.latitude / 1e7, msg.longitude / 1e7)
        elif kind == "PARAM_VALUE":
            view.params[msg.param_id] = float(msg.param_value)
        elif kind == "STATUSTEXT":
            view.statustext.append(msg.text)
            del view.statustext[:-50]
        elif kind == "COMMAND_ACK":
            for pending in self._pending:
                if pending.system_id == sysid and pending.command == msg.command:
                    pending.ack = msg

    def wait_vehicle(self, timeout_s: float = 10.0, system_id: int | None = None) -> VehicleView:
        """Block (on the clock) until an aPad's heartbeat has been heard; return its view."""
        deadline = self.clock.now_us + int(timeout_s * 1e6)
        while True:
            for sysid, view in self.vehicles.items():
                if system_id is None or sysid == system_id:
                    return view
            if self.clock.now_us >= deadline:
                who = "an aPad" if system_id is None else f"aPad {system_id}"
                raise TimeoutError(f"no heartbeat from {who} within {timeout_s:g} s")
            self.clock.sleep(0.05)

    # --- parameters (PARAM protocol) ---------------------------------------------------------

    def param_set(
        self, system_id: int, name: str, value: float, timeout_s: float = 1.0, retries: int = 3,
        component_id: int = mavlink.MAV_COMP_ID_AUTOPILOT1,
    ) -> float:
        """PARAM_SET until the vehicle answers PARAM_VALUE for `name`; return the value it now holds.

        A vehicle that refuses a value answers with the old one: that is a `ValueError` here.
        """
        view = self.vehicles.get(system_id)
        if view is None:
            raise LookupError(f"aPad {system_id} has not been heard")
        msg = mavlink.MAVLink_param_set_message(
            system_id, component_id, name.encode(), float(value), mavlink.MAV_PARAM_TYPE_REAL32
        )
        for _ in range(retries + 1):
            view.params.pop(name, None)
            self.send(msg)
            deadline = self.clock.now_us + int(timeout_s * 1e6)
            self.clock.sleep(0)
            while name not in view.params and self.clock.now_us < deadline:
                self.clock.sleep(min(0.02, timeout_s))
            if name in view.params:
                held = view.params[name]
                if abs(held - float(value)) > 1e-6 * max(1.0, abs(float(value))):
                    raise ValueError(f"aPad {system_id} refused {name}={value:g}; it keeps {held:g}")
                return held
        raise TimeoutError(f"aPad {system_id}: no PARAM_VALUE for {name} after {retries + 1} attempts")

    # --- command protocol -------------------------------------------------------------------

    def command_long(
        self,
        system_id: int,
        command: int,
        params: tuple[float, ...] = (),
        timeout_s: float = 1.0,
        retries: int = 3,
        component_id: int = mavlink.MAV_COMP_ID_AUTOPILOT1,
    ) -> mavlink.MAVLink_command_ack_message:
        """Send COMMAND_LONG until ACKed (`retries` retransmissions, `timeout_s` each).

        Returns the ACK when the result is ACCEPTED; raises `CommandError` otherwise.
        """
        p = (tuple(float(x) for x in params) + (0.0,) * 7)[:7]

        def build(confirmation: int) -> mavlink.MAVLink_message:
            return mavlink.MAVLink_command_long_message(system_id, component_id, command, confirmation, *p)

        return self._run_command(system_id, command, build, timeout_s, retries)

    def command_int(
        self,
        system_id: int,
        command: int,
        frame: int,
        params: tuple[float, float, float, float],
        x: int,
        y: int,
        z: float = 0.0,
        timeout_s: float = 1.0,
        retries: int = 3,
        component_id: int = mavlink.MAV_COMP_ID_AUTOPILOT1,
    ) -> mavlink.MAVLink_command_ack_message:
        """COMMAND_INT (positions as degE7 integers); same ACK/retry protocol as `command_long`."""

        def build(confirmation: int) -> mavlink.MAVLink_message:
            # COMMAND_INT has no confirmation field; the retransmission is byte-identical but its seq.
            return mavlink.MAVLink_command_int_message(
                system_id, component_id, frame, command, 0, 0, *params, x, y, z
            )

        return self._run_command(system_id, command, build, timeout_s, retries)

    def _run_command(
        self,
        system_id: int,
        command: int,
        build: Callable[[int], mavlink.MAVLink_message],
        timeout_s: float,
        retries: int,
    ) -> mavlink.MAVLink_command_ack_message:
        pending = _PendingCommand(system_id, command)
        self._pending.append(pending)
        try:
            for attempt in range(retries + 1):
                pending.ack = None
                self.send(build(attempt))
                deadline = self.clock.now_us + int(timeout_s * 1e6)
                self.clock.sleep(0)
                while True:
                    ack = pending.ack
                    if ack is not None and ack.result == mavlink.MAV_RESULT_IN_PROGRESS:
                        pending.ack = None  # keep waiting for the final result
                        deadline = self.clock.now_us + int(timeout_s * 1e6)
                    elif ack is not None:
                        if ack.result != mavlink.MAV_RESULT_ACCEPTED:
                            raise CommandError(system_id, command, ack.result, _ack_detail(ack))
                        return ack
                    if self.clock.now_us >= deadline:
                        break
                    self.clock.sleep(min(0.02, timeout_s))
            raise CommandError(system_id, command, None, f"{retries + 1} attempts, {timeout_s:g} s each")
        finally:
            self._pending.remove(pending)


def _ack_detail(ack: mavlink.MAVLink_command_ack_message) -> str:
    reason = getattr(ack, "result_param2", 0)
    return f"reason {reason}" if reason else ""
