"""The GCS's MAVLink link: one router between local parties and the aPads' transports.

Every message is decoded once: what arrives on a transport by that transport's parser (streams
keep their own framing), what a local party sends from the object it encoded. Each message then
goes, as a typed and validated record (`gcs.link.telemetry`), into the one `VehicleRegistry`,
its COMMAND_ACKs to the `CommandClient`, and, as the message itself, to every other local party
(the simulated fleet is one). What fails validation is dropped and counted by reason in
`dropped`, and so is what no one may send us: a frame from a transport claiming to come from this
GCS or from a local party (a spoof), telemetry of a system that is not one of the expected aPads
(`apad_ids`). A handler that still raises is caught at the dispatch, counted ("handler_error:NAME"),
kept in `errors` (the last few, with the message) and the loop goes on: no packet ends the link.
The link also sends the GCS heartbeat and records a .tlog of everything that crossed.

`Link` is the GCS's one System (MAVSDK's word): `registry`, `commands` and `params` beside it.
"""

from __future__ import annotations

import logging
from collections import Counter, deque
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from gcs.link.command_protocol import CommandClient, CommandError
from gcs.link.fleet_table import MusselBatch
from gcs.link.params import ParamClient
from gcs.link.registry import VehicleRegistry, VehicleView
from gcs.link.telemetry import GCS_COMPONENT_ID, GCS_SYSTEM_ID, CommandAck, MusselView, Rejected, read
from mavlink_dialect import Codec, Transport, hot, mavlink
from mavlink_dialect.tlog import TlogWriter
from mavlink_dialect.transport import Bell, UdpTransport, ring_on
from missiontime import Clock, seconds_to_us

# 2 Hz: the aPad holds after FS_GCS_TIMEOUT (3 s) of silence, so 1 Hz would tolerate only two lost
# heartbeats in a row (16 needless holds in a 40 min mission at 20 % loss); 2 Hz tolerates five.
HEARTBEAT_PERIOD_S = 0.5
WAIT_POLL_S = 0.05
RELAY_MEMORY = 256  # frames a relaying transport remembers, to relay each once
ERRORS_KEPT = 20  # handler errors kept with their message, for the log and a post-mortem

Handler = Callable[[Any], None]
log = logging.getLogger(__name__)

__all__ = ["GCS_SYSTEM_ID", "CommandError", "Link", "Port", "VehicleView"]


@dataclass(frozen=True)
class _Wiring:
    """What a port and a transport poller use of their link: its own steps, handed to them by the link."""

    out: Callable[[bytes], None]  # to every transport
    loopback: Codec  # parses bare bytes of local parties, once
    deliver: Callable[[Port | None, Any], bool]  # to every local party but the sender
    deliver_batch: Callable[[int, Sequence[bytes], Mapping[str, Any]], None]
    receive: Callable[[Any], bool]  # a message from a transport; True if taken
    relay: Callable[[_TransportPoller, bytes], None]  # to the other transports
    registry: VehicleRegistry


class Port:
    """A local party's way onto the link; `handler` gets every message the others sent.

    A party that holds the message object it encoded passes its bytes to `send_bytes` and the
    object to `send_local`, so nobody parses its bytes back; `send` takes bare bytes (parsed once,
    here, for the others).
    """

    def __init__(self, link: _Wiring, handler: Handler | None, forward: frozenset[int] | None = None,
                 system_id: int | None = None, hears: frozenset[int] | None = None) -> None:
        """`forward`: the message ids of this party that go out to the vehicles (None: all of them);
        a router sends a listener what it uses, as mavlink-router's filters do, and `hears`: the ids
        `handler` is given (None: every one). `system_id`: the party's own MAVLink system; a transport
        frame claiming it is a spoof."""
        self.link = link
        self.handler = handler
        self.forward = forward
        self.system_id = system_id
        self.hears = hears

    def _out(self, data: bytes) -> None:
        if self.forward is None or frame_msg_id(data) in self.forward:
            self.link.out(data)

    def send(self, data: bytes) -> None:
        self._out(data)
        for msg in self.link.loopback.decode(data):
            self.link.deliver(self, msg)

    def send_bytes(self, data: bytes) -> None:
        self._out(data)

    def send_local(self, msg: Any) -> None:
        self.link.deliver(self, msg)

    def send_batch(self, msg_id: int, frames: Sequence[bytes], columns: Mapping[str, Any]) -> None:
        """Many messages of one id at once (`mavlink_dialect.hot`): out to the vehicles in datagrams,
        and into the link as a batch (local parties get none)."""
        if self.forward is None or msg_id in self.forward:
            for data in hot.pack_datagrams(frames):
                self.link.out(data)
        self.link.deliver_batch(msg_id, frames, columns)


def frame_msg_id(frame: bytes) -> int:
    """The message id in a MAVLink 2 (or 1) frame's header, without parsing the frame."""
    if frame[0] == mavlink.PROTOCOL_MARKER_V2:
        return int.from_bytes(frame[7:10], "little")
    return frame[5]


class _TransportPoller:
    """Reads one transport for the scheduler; one parser per transport keeps stream framing apart."""

    def __init__(
        self, link: _Wiring, transport: Transport, forward: frozenset[int] = frozenset(),
        outbound: frozenset[int] | None = None,
    ) -> None:
        self.link = link
        self.transport = transport
        self.codec = Codec(GCS_SYSTEM_ID, GCS_COMPONENT_ID)
        self.forward = forward  # message ids relayed, once accepted, to the other transports
        self.outbound = outbound  # the message ids this transport is sent (None: all)
        self._relayed: deque[tuple[int, int, int]] = deque(maxlen=RELAY_MEMORY)  # (system, seq, msg id)

    def poll(self) -> bool:
        chunks = self.transport.receive()
        for chunk in chunks:
            for msg in self.codec.decode(chunk):
                taken = self.link.receive(msg)
                if taken:
                    self.link.registry.count_frame(msg.get_srcSystem(), msg.get_srcComponent(), msg.get_seq())
                if taken and msg.get_msgId() in self.forward:
                    # A frame heard twice (an echo through another radio, a duplicate) is relayed once.
                    ident = (msg.get_srcSystem(), msg.get_seq(), msg.get_msgId())
                    if ident not in self._relayed:
                        self._relayed.append(ident)
                        self.link.relay(self, bytes(msg.get_msgbuf()))
        return bool(chunks)

    def fileno(self) -> int | None:
        return self.transport.fileno()

    def ring_on(self, bell: Bell) -> bool:
        """The scheduler's doorbell (`missiontime.Doorbell`): rung by the transport if it can."""
        return ring_on(self.transport, bell)


class Link:
    """Routes MAVLink between local parties and aPad transports; one registry of what was heard."""

    def __init__(
        self,
        clock: Clock,
        system_id: int = GCS_SYSTEM_ID,
        component_id: int = GCS_COMPONENT_ID,
        tlog_path: Path | None = None,
        tlog_epoch_us: int = 0,
        append: bool = False,
        apad_ids: Collection[int] | None = None,
        ideal: bool = False,
    ) -> None:
        """`append` continues an existing .tlog (a resumed mission). `apad_ids`: the aPads this GCS
        expects (their telemetry alone is believed); None: whatever vehicle is heard. `ideal`: the event
        platform's ideal link (gcs.mission.platform), which needs no heartbeat to know who is there: the GCS
        sends none, and an aPad once heard stays heard (`VehicleRegistry.silent_us`)."""
        self.clock = clock
        self.codec = Codec(system_id, component_id)
        self.registry = VehicleRegistry(system_id, apad_ids, ideal)
        self.commands = CommandClient(self.send, clock)
        self.params = ParamClient(self.send, self.registry, clock)
        self.dropped: Counter[str] = Counter()  # received messages refused by validation, by reason
        self.errors: deque[tuple[str, str]] = deque(maxlen=ERRORS_KEPT)  # (message, error) a handler raised
        self._local_systems = {system_id}  # a transport frame from one of these is a spoof
        self._pollers: list[_TransportPoller] = []
        self._ports: list[Port] = []
        self._loopback = Codec(system_id, component_id)  # parses bare bytes of local parties, once
        self._tlog = TlogWriter(tlog_path, tlog_epoch_us, append) if tlog_path else None
        self._signing: tuple[bytes, int, Callable[[], int]] | None = None
        self._wiring = _Wiring(self._out, self._loopback, self._deliver, self._deliver_batch, self._receive,
                               self._relay, self.registry)
        self.port = self.attach(None)  # the GCS's own party
        self._heartbeat = mavlink.MAVLink_heartbeat_message(
            mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, mavlink.MAV_STATE_ACTIVE, 3
        )
        if not ideal:
            clock.scheduler.every(HEARTBEAT_PERIOD_S, lambda now_us: self.send(self._heartbeat), "gcs.heartbeat",
                                  clock.now_us)

    @property
    def vehicles(self) -> dict[int, VehicleView]:
        return self.registry.vehicles

    # --- wiring -----------------------------------------------------------------------------

    def add_transport(
        self, transport: Transport, forward: frozenset[int] = frozenset(), outbound: frozenset[int] | None = None,
    ) -> None:
        """Read and write `transport`. `forward`: message ids that, received on it and accepted, are
        relayed to the other transports (a bridge of real aMussels: the aPads dock by their status).
        `outbound`: the only message ids sent to it (None: everything the GCS sends): a bridge radio
        gets the commands for its aMussels, not the simulated fleet's traffic."""
        poller = _TransportPoller(self._wiring, transport, forward, outbound)
        if self._signing is not None:
            poller.codec.enable_signing(*self._signing)
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
            poller.codec.enable_signing(key, link_id, ticks)

    def attach(self, handler: Handler | None, forward: frozenset[int] | None = None,
               system_id: int | None = None, hears: frozenset[int] | None = None) -> Port:
        port = Port(self._wiring, handler, forward, system_id, hears)
        self._ports.append(port)
        if system_id is not None:
            self._local_systems.add(system_id)
        return port

    @property
    def tlog(self) -> TlogWriter | None:
        """The GCS's .tlog writer (None without a log): a checkpoint reads its size, a replay mutes it."""
        return self._tlog

    def udp_ports(self) -> list[int]:
        """The local ports of the link's UDP transports (for endpoints.json)."""
        return [p.transport.local_port for p in self._pollers if isinstance(p.transport, UdpTransport)]

    def close(self) -> None:
        for poller in self._pollers:
            self.clock.scheduler.remove_poller(poller)
            poller.transport.close()
        self._pollers.clear()
        if self._tlog is not None:
            self._tlog.close()
            self._tlog = None

    # --- routing ----------------------------------------------------------------------------

    def send(self, msg: Any) -> None:
        """Encode `msg` as the GCS; out to every aPad, and to every other local party."""
        self._out(self.codec.encode(msg))
        self._deliver(self.port, msg)

    def _out(self, data: bytes) -> None:
        msg_id = -1
        for poller in self._pollers:
            if poller.outbound is not None:
                if msg_id < 0:
                    msg_id = frame_msg_id(data)
                if msg_id not in poller.outbound:
                    continue
            poller.transport.send(data)

    def _receive(self, msg: Any) -> bool:
        """One message from a transport, at the dispatch boundary: whatever it makes a handler
        raise is counted, logged and kept, and the next message is read. True if it was taken."""
        try:
            return self._deliver(None, msg)
        except Exception as exc:  # validation should have stopped it; a bug must not end the link
            name = msg.get_type()
            self.dropped[f"handler_error:{name}"] += 1
            self.errors.append((repr(msg)[:300], f"{type(exc).__name__}: {exc}"[:200]))
            log.warning("handler error on %s: %s: %s", msg, type(exc).__name__, exc)
            return False

    def _relay(self, source: _TransportPoller, data: bytes) -> None:
        for poller in self._pollers:
            if poller is not source:
                poller.transport.send(data)

    def _deliver(self, origin: Port | None, msg: Any) -> bool:
        """One decoded message: recorded, read into the registry once, handed to the other parties.
        False if it was refused (and counted)."""
        if self._tlog is not None:
            self._tlog.write(self.clock.now_us, msg.get_msgbuf())
        src = msg.get_srcSystem()
        if origin is None and src in self._local_systems:  # only a local party speaks as itself
            self.dropped[f"spoofed_source:{msg.get_type()}"] += 1
            return False
        record, msg_id = read(msg), msg.get_msgId()
        if isinstance(record, Rejected):
            self.dropped[record.reason] += 1
            return False
        if isinstance(record, CommandAck):
            if record.target_system in (0, self.codec.system_id):  # not an answer to another GCS
                self.commands.on_ack(src, record)
        elif record is None:
            if origin is not None and src == origin.system_id and msg_id == mavlink.MAVLINK_MSG_ID_HEARTBEAT:
                self.registry.fleet_heard_us = self.clock.now_us  # the fleet's node (its aMussels report by exception)
        else:
            if origin is None and isinstance(record, MusselView) and record.simulated and len(self._local_systems) > 1:
                self.dropped["AMUSSEL_STATUS.source"] += 1  # our simulated fleet is a local party
                return False
            if origin is None and not self.registry.believes(src, record):
                self.dropped[f"{msg.get_type()}.system"] += 1  # not a vehicle we expect, or not yet heard
                return False
            refused = self.registry.apply(src, record, self.clock.now_us)
            if refused is not None:
                self.dropped[refused] += 1
                return False
        for port in self._ports:
            if port is not origin and port.handler is not None and (port.hears is None or msg_id in port.hears):
                port.handler(msg)
        return True

    def _deliver_batch(self, msg_id: int, frames: Sequence[bytes], columns: Mapping[str, Any]) -> None:
        if self._tlog is not None:
            self._tlog.write_many(self.clock.now_us, frames)
        if msg_id == mavlink.MAVLINK_MSG_ID_AMUSSEL_STATUS:
            self.dropped.update(self.registry.mussels.update_batch(MusselBatch.from_wire(columns)))
            self.registry.fleet_heard_us = self.clock.now_us
            self.registry.version += 1

    # --- waiting for vehicles ---------------------------------------------------------------

    def wait_vehicle(self, timeout_s: float = 10.0, system_id: int | None = None) -> VehicleView:
        """Block (on the clock) until an aPad's heartbeat has been heard; return its view."""
        deadline = self.clock.now_us + seconds_to_us(timeout_s)
        while True:
            for sysid, view in self.vehicles.items():
                if system_id is None or sysid == system_id:
                    return view
            if self.clock.now_us >= deadline:
                who = "an aPad" if system_id is None else f"aPad {system_id}"
                raise TimeoutError(f"no heartbeat from {who} within {timeout_s:g} s")
            self.clock.sleep(WAIT_POLL_S)
