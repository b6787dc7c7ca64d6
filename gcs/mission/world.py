"""The one builder of a mission's world: the aMussel fleet, the GCS link and API, and the aPad.

Headless runs (`headless_world`) put the SITL aPad, the fleet and the GCS on one virtual clock, on
either platform (`gcs.mission.platform`): lockstep, the aPad reached over an in-memory pair (or
localhost UDP, or a fault proxy) with real MAVLink bytes both ways; or the event platform, the same
parts on an `EventClock` over the ideal link (no heartbeats, no .tlog, reports by exception, the
fleet stepped only when it changes). The console builds the same world on its own clock, with the
embedded SITL aPad or a real one at an address.
"""

from __future__ import annotations

import functools
import operator
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from acoustic.nanomodem.ports import BytePort, SerialPort
from acoustic.nanomodem.sea import Sea, SeaClient, SilentSea, parse_udp
from apad_sitl.endpoint import SitlVehicle
from gcs.acoustic_net.network import AcousticNetwork
from gcs.belief.duty import scenario_duties
from gcs.belief.energy_budget import EnergyBudget
from gcs.belief.real_fleet import RealFleet
from gcs.link.apad_api import ApadApi, Location
from gcs.link.faultproxy import FaultProxy, LinkFaults
from gcs.link.router import Link
from gcs.loop.control import LoopControl, LoopSettings, LoopStatus
from gcs.loop.energy_sharing import EnergySharingLoop
from gcs.loop.telemetry_pace import MISSION_TELEMETRY_HZ
from gcs.loop.trip_energy import home_now
from gcs.mission.platform import Platform
from gcs.records.events import EventLog
from gcs.records.run_folder import RunFolder
from gcs.scenario.model_params import (
    apad_params,
    call_up_wait_s,
    fleet_params,
    geofence_ring,
    planning_profile,
    sensor_field,
    start_config,
)
from gcs.scenario.reader import ApadConfig, Scenario
from gcs.scenario.tdma_frame import area_range_m
from gcs.swarm.shares import FleetShares
from mavlink_dialect import Codec, Transport, mavlink, memory_pair, open_transport, signing
from mavlink_dialect.transport import UdpTransport
from missiontime import Clock, VirtualClock, seconds_to_us
from missiontime.event_clock import EventClock
from mussel_sim.battery import charge_profile, discharge_profile
from mussel_sim.comms import FLEET_COMPONENT_ID, FLEET_SYSTEM_ID, CommsConfig, FleetRunner
from mussel_sim.day_ledger import day_us
from mussel_sim.fleet_state import initial_state
from mussel_sim.geo import LocalFrame
from mussel_sim.inbox_checks import HEARD_MESSAGES
from mussel_sim.placement import load_area
from mussel_sim.recorder import Recorder
from mussel_sim.startconfig import StartConfig

# .tlog stamps of lockstep runs start here (2020-06-12 00:00 UTC), so logs are repeatable.
LOCKSTEP_EPOCH_US = 1_591_920_000_000_000
# The geofence is the scenario's water area grown by this much (GPS error, drift of the aMussels).
GEOFENCE_BUFFER_M = 10.0
GCS_SIGNING_LINK_ID = 1
# What the aPad uses of the fleet's traffic: positions to dock by. Sensor readings and the fleet's
# warnings are for the GCS alone, so they stay off the aPad link.
APAD_HEARS_FROM_FLEET = frozenset({mavlink.MAVLINK_MSG_ID_AMUSSEL_STATUS})
# What a bridge of real aMussels is sent: their commands and the GCS heartbeat, nothing of the
# simulated fleet's traffic or the aPads' (a radio link has little to spare).
BRIDGE_HEARS = frozenset({mavlink.MAVLINK_MSG_ID_AMUSSEL_COMMAND, mavlink.MAVLINK_MSG_ID_AMUSSEL_SLEEP_ORDER,
                          mavlink.MAVLINK_MSG_ID_HEARTBEAT})


@dataclass(frozen=True)
class LinkOptions:
    """How the GCS reaches its aPad: an embedded SITL aPad (default) or a vehicle at `connect`."""

    # Real or separate aPads at these addresses (udp:, tcp:, serial:), comma-separated: one link
    # each; one address may also carry several aPads (routing is by system id).
    connect: str | None = None
    sitl_medium: str = "memory"  # embedded aPad: "memory" (in-memory pair) or "udp" (localhost sockets)
    faults: LinkFaults | None = None  # not None: embedded aPad over real UDP through a FaultProxy
    signing_key: bytes | None = None  # MAVLink 2 signing on both ends
    geofence_buffer_m: float | None = GEOFENCE_BUFFER_M  # None: no geofence
    # Where real aMussels report (AMUSSEL_STATUS, simulated = 0): an address the GCS listens on
    # (udp:HOST:PORT, serial:DEV). Their statuses are relayed to the aPads, which dock by them.
    bridge: str | None = None
    # Embedded aPads that go silent for good at a mission time: (system id, t_s) (`vil run --fail-apad`).
    fail_apads: tuple[tuple[int, float], ...] = ()
    # An acoustic scenario's GCS nanomodem on this serial device (a real unit or `vil modem`'s pty), and
    # where `vil modem --sea` carries the simulated aMussels' modems (udp:HOST:PORT; None: not on the water).
    # No modem: both emulated in-process.
    modem: str | None = None
    sea: str | None = None


@dataclass
class World:
    scenario: Scenario
    clock: Clock
    link: Link
    api: ApadApi
    fleet: FleetRunner
    frame: LocalFrame
    start: StartConfig
    homes: dict[int, Location]  # where each aMussel started, and goes back to
    events: EventLog
    vehicles: dict[int, SitlVehicle] = field(default_factory=dict)  # the embedded SITL aPads, by system id
    proxies: list[FaultProxy] = field(default_factory=list)  # fault-injection proxies, one per embedded aPad
    real: RealFleet | None = None  # estimates of the real aMussels heard on the bridge
    geofence_deg: list[tuple[float, float]] = field(default_factory=list)  # (lat, lon) ring; empty: none
    folder: RunFolder | None = None  # where the logs go; None: no logs
    options: LinkOptions = field(default_factory=lambda: LinkOptions())  # how the aPads are reached
    acoustic: AcousticNetwork | None = None  # [acoustic] enabled: the channel, the modems, belief vs truth
    platform: Platform = Platform.LOCKSTEP  # what it runs on: every byte on the wire, or discrete events

    @property
    def vehicle(self) -> SitlVehicle | None:
        """The (first) embedded SITL aPad, if any."""
        return next(iter(self.vehicles.values()), None)

    @property
    def proxy(self) -> FaultProxy | None:
        return self.proxies[0] if self.proxies else None

    def request_telemetry(self, rates_hz: dict[int, float] | None = None, apad_id: int | None = None) -> None:
        """Ask an aPad for the mission's telemetry rates; one it never grants (a lossy link) keeps
        its default rate and is logged as a `telemetry_rate_failed` event, not fatal."""
        sysid = self.scenario.apad.system_id if apad_id is None else apad_id
        for msg_id, exc in self.api.set_telemetry_rates(rates_hz or MISSION_TELEMETRY_HZ, sysid).items():
            known = mavlink.mavlink_map.get(msg_id)
            self.events.emit(self.clock.time(), "telemetry_rate_failed", message=known.msgname if known else msg_id,
                             what=str(exc), **({"apad": sysid} if len(self.scenario.apads) > 1 else {}))

    def mission_loop(
        self, control: LoopControl | None = None, apad_id: int | None = None, shares: FleetShares | None = None,
        clock: Clock | None = None, status: LoopStatus | None = None,
    ) -> EnergySharingLoop:
        """The energy-sharing loop of one aPad (default the first); with several, each on its own
        process `clock` and within its share of `shares`; `status`: a resumed mission's."""
        s = self.scenario
        a = next(a for a in s.apads if apad_id is None or a.system_id == apad_id)
        settings = loop_settings(s, a, sorted(self.homes))
        registry = self.link.registry  # what of the aPad's battery its waits read: the mission's end, a charge done
        registry.watch_battery(a.system_id, "mission end", functools.partial(operator.ge, settings.battery_end_v))
        if settings.energy is not None:
            registry.watch_battery(a.system_id, "charged", settings.energy.charged)
        clock = clock or self.clock
        api = self.api if clock is self.clock else self.api.on_clock(clock)
        loop = EnergySharingLoop(api, clock, settings, self.homes, a.system_id, self.events, control, shares,
                                 self.real, status, self.acoustic)
        if settings.energy is not None:  # a rolling wait reads whether to head home (`trip_energy.home_now`)
            registry.watch_battery(a.system_id, "home", functools.partial(home_now, loop.knows))
        if self.acoustic is not None:
            self.acoustic.plans(a.system_id, loop.knows)  # belief against truth, as this loop plans with it
        return loop

    def mute_logs(self, muted: bool) -> None:
        """Stop (or restart) writing the logs: a resumed lockstep mission replays up to its checkpoint
        with them muted, since they already hold that stretch."""
        if self.link.tlog is not None:
            self.link.tlog.muted = muted
        self.events.muted = muted
        for vehicle in self.vehicles.values():
            if vehicle.log is not None:
                vehicle.log.mute(muted)

    def log_sizes(self) -> dict[str, int]:
        """Each log's length now, by file name in the run folder (flushed first): a checkpoint keeps
        them, and a resume cuts the logs back to them."""
        sizes: dict[str, int] = {}
        if self.link.tlog is not None:
            sizes[self.link.tlog.path.name] = self.link.tlog.size()
        if self.folder is not None:
            sizes[self.folder.events.name] = self.events.bytes
        for vehicle in self.vehicles.values():
            if vehicle.log is not None:
                sizes |= {path.name: size for path, size in vehicle.log.sizes().items()}
        return sizes

    def close(self) -> None:
        for vehicle in self.vehicles.values():
            vehicle.close()
        for proxy in self.proxies:
            proxy.close()
        if self.acoustic is not None:
            self.acoustic.close()
        self.link.close()
        self.events.close()


def build_world(
    scenario: Scenario,
    clock: Clock,
    out_dir: Path | None = None,
    options: LinkOptions | None = None,
    epoch_us: int = LOCKSTEP_EPOCH_US,
    mission_start_us: int | None = None,
    append_logs: bool = False,
    muted_logs: bool = False,
    platform: Platform = Platform.LOCKSTEP,
) -> World:
    """The one builder of a mission's world on `clock`: the simulated fleet, the GCS link and API,
    and the aPad, embedded (SITL) or reached at `options.connect`. Used by `vil run`, `vil gcs`
    and the tests. `platform` EVENT (on an `EventClock`): the same parts over the ideal link.

    `epoch_us` is the Unix time of mission time 0 in the logs (lockstep: a fixed date, so logs
    repeat). `mission_start_us` is when the mission began (default: now; a resumed mission began
    earlier); `append_logs` continues the folder's logs instead of starting them afresh; `muted_logs`
    writes nothing to them from the start (a lockstep resume replays what they hold: `World.mute_logs`).
    """
    options = options or LinkOptions()
    event = platform is Platform.EVENT
    rng = np.random.default_rng(scenario.seed)
    start_us = clock.now_us if mission_start_us is None else mission_start_us
    area = load_area(scenario.fleet.area)
    config, frame = start_config(scenario, area, rng)
    params = fleet_params(scenario)
    folder = RunFolder(out_dir) if out_dir is not None else None
    if folder is not None:
        folder.path.mkdir(parents=True, exist_ok=True)
    apad_ids = frozenset(a.system_id for a in scenario.apads)  # only their telemetry is believed
    link = Link(clock, tlog_path=folder.gcs_tlog if folder and not event else None, tlog_epoch_us=epoch_us,
                append=append_logs, apad_ids=apad_ids, ideal=event)
    events = EventLog(folder.events if folder else None, append=append_logs)
    port = link.attach(None, forward=APAD_HEARS_FROM_FLEET, system_id=FLEET_SYSTEM_ID, hears=HEARD_MESSAGES)
    state = initial_state(config, frame, params, clock.now_us)
    fleet = FleetRunner(
        state, params, rng, frame,
        Codec(FLEET_SYSTEM_ID, FLEET_COMPONENT_ID), port.send_bytes, sensor_field(scenario, area, frame),
        CommsConfig(status_rate_hz=scenario.fleet.status_rate_hz, sensors_rate_hz=scenario.fleet.sensors_rate_hz,
                    status_keepalive_s=scenario.fleet.status_keepalive_s,
                    apad_ids=apad_ids, commanders=frozenset({link.codec.system_id}),
                    wifi_at_surface_only=scenario.acoustic.enabled),
        recorder=Recorder(state.ids, sinking_counts_active=scenario.mission.sinking_counts_active,
                          start_us=state.time_us, day_us=day_us(scenario.mission.theta)),
        local=port.send_local, local_batch=port.send_batch,
    )
    port.handler = fleet.handle
    fleet.register(clock.scheduler, clock.now_us, end_us=start_us + seconds_to_us(scenario.mission.duration_s),
                   events=event)
    buffer_m = options.geofence_buffer_m
    fence = geofence_ring(area, frame, buffer_m) if buffer_m is not None else []
    api = ApadApi(link, clock, default_apad=scenario.apad.system_id, geofence_deg=fence or None)
    homes = {
        int(i): Location(float(lat), float(lon))
        for i, lat, lon in zip(config.ids, config.lat_deg, config.lon_deg, strict=True)
    }
    world = World(scenario, clock, link, api, fleet, frame, config, homes, events, geofence_deg=fence, folder=folder,
                  options=options, platform=platform)
    if isinstance(clock, EventClock):  # its waits look when the GCS hears anything
        clock.hears(lambda: link.registry.news)
        clock.hears(lambda: link.registry.mussels.version)
        if fleet.event_steps is not None:  # and it reads the aMussels where lockstep's keep-alive would say
            link.registry.refresh_positions = fleet.event_steps.refresh_positions
            fleet.event_steps.keepalive.deliver = link.registry.mussels.moved
    world.mute_logs(muted_logs)
    if scenario.acoustic.enabled:
        world.acoustic = AcousticNetwork.build(
            clock, fleet, link, events, scenario.acoustic,
            {a.system_id: (a.home_lat_deg, a.home_lon_deg) for a in scenario.apads}, scenario.seed,
            area_range_m(scenario), serial_unit(options, clock), apad_modems=options.connect is None)
    world.real = RealFleet(link.registry.mussels, link.registry.mussel_heard_us,
                           discharge_profile(scenario.fleet.discharge), charge_profile(scenario.fleet.charge),
                           scenario.mission.theta)
    if options.bridge is not None:
        link.add_transport(open_transport(options.bridge, listen=True),
                           forward=frozenset({mavlink.MAVLINK_MSG_ID_AMUSSEL_STATUS}), outbound=BRIDGE_HEARS)
    if options.connect is not None:
        for address in options.connect.split(","):
            link.add_transport(open_transport(address.strip()))
    else:
        _embed_sitl(world, options, epoch_us, append_logs, muted_logs)
    if options.signing_key is not None:
        link.enable_signing(options.signing_key, GCS_SIGNING_LINK_ID,
                            lambda: signing.timestamp_ticks(epoch_us, clock.now_us))
        # The aPad takes nothing unsigned, the swarm's AMUSSEL_STATUS included (its own stream: the fleet's ids).
        fleet.codec.enable_signing(options.signing_key, GCS_SIGNING_LINK_ID,
                                   lambda: signing.timestamp_ticks(epoch_us, clock.now_us))
    return world


def serial_unit(options: LinkOptions, clock: Clock) -> tuple[BytePort, Sea] | None:
    """The GCS's nanomodem on its serial device and the sea of the simulated aMussels' modems (its
    socket a poller of the clock's scheduler), or None: both in-process."""
    if options.modem is None:
        return None
    port = SerialPort(options.modem)
    sea: Sea = SilentSea() if options.sea is None else SeaClient(*parse_udp(options.sea))
    if isinstance(sea, SeaClient):
        clock.scheduler.add_poller(sea)
    return port, sea


def _embed_sitl(world: World, options: LinkOptions, epoch_us: int, append_logs: bool, muted_logs: bool) -> None:
    """The scenario's SITL aPads on the world's clock, each over an in-memory pair of real MAVLink
    bytes, localhost UDP, or real UDP through a `FaultProxy` whose delays run on the same clock;
    the GCS link routes by system id over all of them."""
    for a in world.scenario.apads:
        _embed_one(world, a, options, epoch_us, append_logs, muted_logs)
    for sysid, t_s in options.fail_apads:
        vehicle = world.vehicles.get(sysid)
        if vehicle is None:
            raise ValueError(f"--fail-apad {sysid}: the scenario has no aPad {sysid}")
        # Silent for good: its tasks stop, its transport closes; what it held stays on it.
        _once(world.clock, seconds_to_us(t_s), vehicle.close, f"fail.apad{sysid}")


def _once(clock: Clock, at_us: int, action: Callable[[], None], name: str) -> None:
    """Run `action` once, at mission time `at_us`."""
    def fire(now_us: int) -> None:
        task.active = False
        action()

    task = clock.scheduler.every(1.0, fire, name, at_us)


def _embed_one(
    world: World, a: ApadConfig, options: LinkOptions, epoch_us: int, append_logs: bool, muted_logs: bool,
) -> None:
    s, clock = world.scenario, world.clock
    gcs_end: Transport
    apad_end: Transport
    if options.faults is not None:
        apad_udp = UdpTransport("127.0.0.1", 0, listen=True, now_s=clock.time)  # peers age in mission time
        # Each aPad its own proxy, seeded apart, so one aPad's faults do not shift another's draws.
        faults = replace(options.faults, seed=options.faults.seed + 1000 * len(world.proxies))
        proxy = FaultProxy(clock, ("127.0.0.1", apad_udp.local_port), faults)
        world.proxies.append(proxy)
        gcs_end, apad_end = UdpTransport("127.0.0.1", proxy.listen_port, listen=False), apad_udp
    elif options.sitl_medium == "udp":
        apad_udp = UdpTransport("127.0.0.1", 0, listen=True, now_s=clock.time)  # peers age in mission time
        gcs_end, apad_end = UdpTransport("127.0.0.1", apad_udp.local_port, listen=False), apad_udp
    else:
        gcs_end, apad_end = memory_pair(f"apad{a.system_id}")
    vehicle = SitlVehicle(
        apad_end, apad_params(s, a), a.home_lat_deg, a.home_lon_deg, system_id=a.system_id, modem=_apad_modem(world, a),
        current_mps=(s.environment.current_east_mps, s.environment.current_north_mps),
        log_dir=world.folder.path if world.folder else None, log_epoch_us=epoch_us, signing_key=options.signing_key,
        geofence_deg=world.geofence_deg or None, log_append=append_logs, ideal_link=world.platform is Platform.EVENT,
    )
    if vehicle.log is not None:
        vehicle.log.mute(muted_logs)  # before its first event, at attach
    vehicle.attach(clock.scheduler, clock.now_us)
    world.link.add_transport(gcs_end)
    world.vehicles[a.system_id] = vehicle


def _apad_modem(world: World, a: ApadConfig) -> tuple[BytePort, Callable[[], None]] | None:
    """The aPad's own nanomodem on the acoustic network's water (its port, and what puts it where the
    aPad is before each write); None without the channel, or where the GCS's unit speaks for it."""
    network = world.acoustic
    modem = network.apad_modems.get(a.system_id) if network is not None else None
    if network is None or modem is None:
        return None
    return modem.modem_end, lambda: network.place_apad_unit(a.system_id, world.vehicles[a.system_id].position_deg)


def headless_world(
    scenario: Scenario, out_dir: Path | None = None, options: LinkOptions | None = None,
    append_logs: bool = False, muted_logs: bool = False, platform: Platform = Platform.LOCKSTEP,
) -> World:
    """Everything on one virtual clock from mission time 0, run at CPU speed: lockstep's, or the event
    platform's `EventClock`."""
    clock = EventClock() if platform is Platform.EVENT else VirtualClock()
    return build_world(scenario, clock, out_dir, options, mission_start_us=0, append_logs=append_logs,
                       muted_logs=muted_logs, platform=platform)


def loop_settings(s: Scenario, a: ApadConfig, ids: list[int]) -> LoopSettings:
    """The settings of aPad `a`'s loop in scenario `s` (`ids`: the simulated fleet's aMussels)."""
    return LoopSettings(
        mission=s.mission,
        acoustic_range_m=s.fleet.acoustic_range_m,
        dock_reach_m=a.dock_reach_m,
        battery_end_v=a.battery_end_v,
        apad_speed_mps=a.speed_mps,
        mussel_surfacing_s=s.fleet.surfacing_time_s,
        surfacing_timeout_s=call_up_wait_s(s, LoopSettings.surfacing_timeout_s),  # sleepers wake first
        mussel_discharge=planning_profile(s).discharge,  # fleet.profile's battery models
        mussel_charge=planning_profile(s).charge.name,
        duties=scenario_duties(s, ids),  # each aMussel's own profile
        energy=EnergyBudget.of(apad_params(s, a), a.speed_mps),
        home=(a.home_lat_deg, a.home_lon_deg),
    )
