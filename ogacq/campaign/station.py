"""The one place that maps a campaign's configuration to real or simulated endpoints.

Either way the campaign talks to the same drivers: the indicator drivers on
serial ports (device paths, pseudo-terminals or ``socket://`` URLs) and the
Modbus controller client. With a ``[simulator]`` table the endpoints are the
built-in simulator's, started here; nothing else knows the difference. Campaigns,
the wizard (its instrument checks and its rehearsal) and ``ogacq sim`` all open
gauges, controllers and the simulator through this module only.

Joint offsets: a profile without an offset register (IAI) gets the software
offset table named by ``[controller] offsets_file`` loaded into the controller
client, so every campaign commands positions with the offsets in force; the
offsets in force are recorded in the station description once homed, because
an identified joint offset is only meaningful relative to them.
"""

from __future__ import annotations

import contextlib
import hashlib
import math
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ogacq_drivers.axes.controller import AxisController
from ogacq_drivers.axes.identification import identify, simulated_by_identity
from ogacq_drivers.axes.modbus_link import ModbusLink
from ogacq_drivers.axes.preflight import PreflightError, check_home, check_identity, probe_move
from ogacq_drivers.axes.profile import Profile, load_profile
from ogacq_drivers.axes.reconnect import ReconnectPolicy, reconnect
from ogacq_drivers.axes.reference import Path as AxisPath
from ogacq_drivers.axes.reference import assess_reference
from ogacq_drivers.errors import DeviceTimeout, DriverError, InputError, LinkError
from ogacq_drivers.indicators import backend, open_indicator
from ogacq_drivers.indicators.base import StableReading
from ogacq_drivers.indicators.concurrent import ConcurrentReader, Settled
from ogacq_drivers.indicators.rest import sample_variance
from ogacq_drivers.link import open_link
from ogacq.campaign.campaign_file import (
    AxisEndpoint,
    AxisScaleSpec,
    Campaign,
    ControllerSpec,
    GaugeSpec,
    SimulatorSpec,
    is_modbus_tcp,
    scale_name,
)
from ogacq.logs import logger
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import AXES
from ogacq.protocol.plan import Read, SettleRule, StabilityRule
from ogacq.protocol.runner import CampaignStopped
from ogacq.protocol.station import GaugeReadings, GaugeValue, SettledGauge
from ogacq.session.records import ReconnectRecord, Record, ReferenceRecord
from ogacq.writeback.endpoint_lock import controller_keys, holding, maps_key
from ogacq.writeback.table import read_offset_table

if TYPE_CHECKING:
    from ogacq.sim.stack import SimulatorStack

log = logger(__name__)


@dataclass
class DeviceStation:
    """A controller and six gauges behind the runner's ``Station`` contract
    (``ogacq.protocol.station``)."""

    controller: AxisController
    indicators: dict[str, Any]
    clock_s: Callable[[], float]  # machine time, seconds
    speed: float = 1.0  # machine time per real time (the simulator may run faster)
    description: dict[str, Any] = field(default_factory=dict)
    simulator: SimulatorStack | None = None
    reconnect: ReconnectPolicy = field(default_factory=ReconnectPolicy)
    # Where events of the station go into the session (set once it is open).
    record_event: Callable[[Record], None] = lambda record: None
    # An axis that lost its reference is homed again unattended (the campaign then
    # checks a posture); False: the campaign stops instead ([controller] rehome_after_loss).
    rehome_after_loss: bool = True
    _t0: float = 0.0
    # A move lost its connection: even if a later request connected again on its own,
    # the axes are stopped and their state re-read before anything else moves.
    _link_lost: bool = False
    _reader: ConcurrentReader | None = None
    # Joint coordinates last reached, and the target of the move under way: where a
    # stop may have left each axis.
    _reached: dict[str, float] | None = None
    _heading: dict[str, float] | None = None
    # Homed again after a loss: the runner checks a posture before it goes on.
    _check_requested: bool = False

    def close(self) -> None:
        """Let the gauge readers go (before the gauges' lines close)."""
        if self._reader is not None:
            self._reader.close()
            self._reader = None

    def prepare(self) -> None:
        """Servo on and home: every campaign starts from a known position, with the
        joint offsets in force recorded (a home offset takes effect at this homing)."""
        # before homing, before any set-point: a plausible status and values (a
        # wrong word order reads 65,536 times too far), then the home value, then a
        # probe that cannot lurch (see drivers/axes/preflight.py)
        check_identity(self.controller)
        self.controller.enable()
        self.controller.home()
        check_home(self.controller)
        probe_move(self.controller)
        statuses = self.controller.home()  # back to the known start the probe move left
        self._reached = {a: s.position_mm for a, s in statuses.items()}
        self.description.setdefault("controller", {})["offsets_mm"] = \
            self.controller.read_offsets()
        self._t0 = self.clock_s()

    def move(self, q_mm: tuple[float, float, float], timeout_s: float,
             ) -> tuple[float, float, float]:
        targets = dict(zip(AXES, q_mm, strict=True))
        self._heading = targets
        try:
            self.controller.move_to(targets, wait=True, timeout_s=timeout_s / self.speed)
        except LinkError:
            self._link_lost = True
            raise
        resolved = self.controller.resolved_targets_mm(targets)
        self._reached, self._heading = resolved, None
        x, y, z = (resolved[a] for a in AXES)
        return x, y, z

    def read_gauges(self, step: Read, gauges: Sequence[str], rule: StabilityRule,
                    ) -> GaugeReadings:
        """A stable value of each gauge, all read at once (one line after another only
        where they share it), or the error each raised."""
        out = self._gauge_reader().read_stable_many(gauges, rule.readings, rule.tolerance_mm,
                                                    rule.timeout_s)
        return [(g, r if isinstance(r, DriverError) else _gauge_value(r))
                for g, r in out.items()]

    def read_settled(self, step: Read, gauges: Sequence[str], rule: SettleRule,
                     ) -> dict[str, SettledGauge | DriverError]:
        """The gauges read at once from now (the axes in position) until each one is at
        rest by ``rule``, at most ``rule.bound_s`` of machine time."""
        out = self._gauge_reader().settle_many(
            gauges, window_s=rule.window_s, bound_s=rule.bound_s,
            display_step_mm=rule.display_step_mm, clock=self.clock_s)
        return {g: r if isinstance(r, DriverError) else _settled(r) for g, r in out.items()}

    def read_scale(self, axis: str, rule: SettleRule, stability: StabilityRule,
                   ) -> tuple[GaugeValue, SettledGauge]:
        """The scale along ``axis`` read from now until at rest by ``rule`` (its display
        step in the rule), as a leg's gauges are after a move; one not at rest within
        the bound is read afresh by ``stability``. Its value and how it settled; a
        DriverError when it cannot be read."""
        name = scale_name(axis)
        if name not in self.indicators:
            raise InputError("axis_scale", f"no scale along the {axis} axis is declared "
                             f"([axis_scale.{axis}] in the campaign file)")
        out = self._gauge_reader().settle_many(
            [name], window_s=rule.window_s, bound_s=rule.bound_s,
            display_step_mm=rule.display_step_mm, clock=self.clock_s)[name]
        if isinstance(out, DriverError):
            raise out
        settled = _settled(out)
        if settled.value is not None:
            return settled.value, settled
        again = self._gauge_reader().read_stable_many(
            [name], stability.readings, stability.tolerance_mm, stability.timeout_s)[name]
        if isinstance(again, DriverError):
            raise again
        return _gauge_value(again), settled

    def _gauge_reader(self) -> ConcurrentReader:
        if self._reader is None:
            self._reader = ConcurrentReader(self.indicators)
        return self._reader

    def campaign_time_s(self) -> float:
        return self.clock_s() - self._t0

    def settle(self, seconds: float) -> None:
        time.sleep(seconds / self.speed)

    def stop_axes(self) -> None:
        self.controller.stop()

    def recover_axes(self) -> bool:
        """Reset alarms and switch the drives back on (a CiA 402 fault drops the power
        stage); True when every axis is ready to move again. A connection lost (or
        gone silent) is first reconnected within the station's reconnect policy,
        the axes stopped and their state re-read and recorded. Then the drives say
        whether each axis kept its reference (:func:`assess_reference`); where one
        did not, every axis is homed again before any set-point (and the runner
        checks a posture), or the campaign stops when that is not allowed."""
        cause = "alarm"
        try:
            if self._link_lost or not all(link.connected for link in self.controller.links):
                cause = "reconnect"
                self._reconnect()
            try:
                ready = self._reset_and_enable()
            except (LinkError, DeviceTimeout):  # lost while recovering, or silent
                cause = "reconnect"
                self._reconnect()
                ready = self._reset_and_enable()
            if ready:
                self._restore_reference(cause)
            return ready
        except PreflightError as exc:  # the re-homed drive is not what it was
            raise CampaignStopped(str(exc)) from exc
        except DriverError:
            return False

    def take_check_request(self) -> bool:
        """True once after the axes were homed again: the runner checks a posture."""
        requested, self._check_requested = self._check_requested, False
        return requested

    def _restore_reference(self, cause: str) -> None:
        """Ask the drives whether the reference survived; home again where it did not."""
        if not self.controller.reports_reference:
            # the drive cannot say whether an alarm or a lost link cost it its reference
            # (switched off and on between two polls, it would read the same): no
            # set-point on this client's memory of a homing
            self.controller.forget_reference()
        paths = None
        if self._reached is not None:
            heading = self._heading or self._reached
            paths = {a: AxisPath(self._reached[a], heading[a]) for a in self._reached}
        found = assess_reference(self.controller, paths)
        axes = {a: r.as_dict() for a, r in found.items()}
        lost = [r for r in found.values() if not r.kept]
        if not lost:
            self.record_event(ReferenceRecord(event="kept", cause=cause, axes=axes))
            return
        self.controller.forget_reference()  # no set-point before the homing
        why = "; ".join(r.describe() for r in lost)
        log.warning("axes %s lost their reference after a %s: %s",
                    ", ".join(r.axis for r in lost), cause, why)
        if not self.rehome_after_loss:
            message = (f"axis {', '.join(r.axis for r in lost)} lost its position reference "
                       f"({why}); homing unattended is not allowed ([controller] "
                       "rehome_after_loss = false): home the machine, then `ogacq resume` "
                       "(it checks a posture against the readings on file)")
            self.record_event(ReferenceRecord(event="lost", cause=cause, axes=axes,
                                              message=message))
            raise CampaignStopped(message)
        self.record_event(ReferenceRecord(event="lost", cause=cause, axes=axes, message=why))
        check_identity(self.controller)  # plausible values before homing, as at the start
        statuses = self.controller.home()
        check_home(self.controller)
        self._reached, self._heading = {a: s.position_mm for a, s in statuses.items()}, None
        self._check_requested = True
        self.record_event(ReferenceRecord(
            event="rehomed", cause=cause,
            axes={a: {"position_mm": round(s.position_mm, 6)} for a, s in statuses.items()}))

    def _reset_and_enable(self) -> bool:
        self.controller.reset_alarms()
        self.controller.enable()
        return not any(s.fault or s.alarm_code or not s.servo_on
                       for s in self.controller.read_status().values())

    def _reconnect(self) -> None:
        try:
            back = reconnect(self.controller, self.reconnect)
        except LinkError as exc:
            self.record_event(ReconnectRecord(connected=False,
                                              attempts=self.reconnect.attempts,
                                              message=str(exc)))
            raise
        self._link_lost = False
        self.record_event(ReconnectRecord(connected=True, attempts=back.attempts,
                                          axes_stopped=True, positions_mm=back.positions_mm,
                                          alarms=back.alarms))


def _gauge_value(stable: StableReading) -> GaugeValue:
    frame = stable.readings[-1].frame.decode("ascii", errors="replace").strip()
    values = [r.value_mm for r in stable.readings]
    sd = math.sqrt(sample_variance(values)) if len(values) > 1 else None
    # 0.1 nm: below any indicator's step, so the session holds no float noise
    return GaugeValue(stable.value_mm, frame, stable.where, len(values),
                      None if sd is None else round(sd, 7))


def _settled(found: Settled) -> SettledGauge:
    return SettledGauge(None if found.reading is None else _gauge_value(found.reading),
                        found.waited_s, found.values,
                        None if found.reference is None else found.reference.u_mm,
                        found.measured,
                        None if found.unjudged is None else _gauge_value(found.unjudged))


def _controller_link(spec: ControllerSpec, profile: Profile, endpoint: str) -> ModbusLink:
    """A link to ``endpoint`` (host:port for TCP, else a serial device)."""
    if is_modbus_tcp(endpoint):
        host, _, port = endpoint.rpartition(":")
        return ModbusLink.for_profile(profile, transport="tcp", host=host, port=int(port),
                                      timeout_s=spec.timeout_s)
    return ModbusLink.for_profile(profile, transport="rtu", serial_port=endpoint,
                                  baudrate=spec.baudrate, timeout_s=spec.timeout_s)


def start_simulator(machine: MachineSpec, sim: SimulatorSpec, *, modbus_port: int = 0,
                    ) -> SimulatorStack:
    """The built-in simulator a ``[simulator]`` table describes, started: the one
    recipe (campaigns, the wizard's rehearsal, ``ogacq sim``), so that a resumed
    campaign meets the same hidden machine. ``modbus_port``: the Modbus TCP port
    (0: any free one)."""
    # Loaded here, not with the module: every command imports the station, and the
    # simulator's Modbus server and gauge emulators add ~50 ms to each start.
    from ogacq.sim.stack import SimulatorConfig, SimulatorStack
    from ogacq.sim.truth import random_truth, read_effects

    truth = random_truth(sim.seed)
    if sim.effects is not None:
        truth = read_effects(sim.effects, truth)
    if sim.noise_mm is not None:
        truth.noise_mm = sim.noise_mm
    # the shop's temperature is physics: the legs are longer when it is warm
    truth = truth.at_temperature(machine, sim.ambient_c)
    return SimulatorStack(SimulatorConfig(machine, truth, profile=sim.profile,
                                          ambient_c=sim.ambient_c,
                                          speed=sim.speed, seed=sim.seed,
                                          gauge_layout=sim.gauge_layout,
                                          gauge_protocol=sim.gauge_protocol,
                                          gauge_protocols=dict(sim.gauge_protocols),
                                          modbus_port=modbus_port,
                                          line_speed=sim.speed if sim.line_at_speed
                                          else 1.0, axis_scales=sim.axis_scales,
                                          scale_resolution_mm=sim.scale_resolution_mm)
                          ).start()


def simulator_scales(simulator: SimulatorStack) -> dict[str, AxisScaleSpec]:
    """Scale specs pointing at a running simulator's axis scales."""
    return {axis: AxisScaleSpec(protocol=s["protocol"], port=s["port"],
                                serial=f"sim-scale-{axis}",
                                resolution_mm=simulator.config.scale_resolution_mm)
            for axis, s in simulator.info().get("axis_scales", {}).items()}


def simulator_endpoints(simulator: SimulatorStack) -> tuple[ControllerSpec, list[GaugeSpec]]:
    """Controller and gauge specs pointing at a running simulator's endpoints."""
    info = simulator.info()
    m = info["modbus"]
    port = f"{m['host']}:{m['port']}" if m["transport"] == "tcp" else m["port"]
    axes = {axis: AxisEndpoint(f"{a['host']}:{a['port']}" if a["transport"] == "tcp"
                               else a["port"], a["device_ids"][axis])
            for axis, a in info.get("modbus_axes", {}).items()}
    controller = ControllerSpec(m["profile"], "" if axes else port, m.get("baudrate"),
                                axes=axes)
    gauges = [GaugeSpec(key, g["protocol"], g["port"], channel=g.get("channel"),
                        serial=f"sim-{key}") for key, g in info["gauges"].items()]
    return controller, gauges


@contextlib.contextmanager
def open_controller(spec: ControllerSpec) -> Iterator[AxisController]:
    """The axis controller a ``[controller]`` table names, with its software offset
    table loaded when it has one; the link is closed on leaving."""
    profile = load_profile(spec.profile)
    software = None
    if spec.offsets_file is not None:
        table = read_offset_table(spec.offsets_file)
        if not table.exists:
            log.warning("offset table %s does not exist yet: software offsets are zero "
                        "(`ogacq offsets write` creates it)", spec.offsets_file)
        software = table.offsets_mm
        _check_software_offsets(table.path, software, profile)
    with contextlib.ExitStack() as stack:
        # one process at a time moves or writes these drives and the maps they apply
        units = {**profile.device_ids, **spec.device_ids()}
        stack.enter_context(holding([
            *controller_keys({a: spec.port_of(a) for a in profile.device_ids}, units),
            *([maps_key(spec.maps_file)] if spec.maps_file is not None else [])]))
        # one link per distinct endpoint: the three axes on one bus, or a drive per address
        links: dict[str, ModbusLink] = {}
        per_axis: dict[str, ModbusLink] = {}
        for axis in profile.device_ids:
            endpoint = spec.port_of(axis)
            if endpoint not in links:
                links[endpoint] = _controller_link(spec, profile, endpoint)
                stack.callback(links[endpoint].close)
                links[endpoint].connect()
            per_axis[axis] = links[endpoint]
        yield AxisController(profile, per_axis, device_ids=spec.device_ids(),
                             software_offsets_mm=software)


def _check_software_offsets(path: Path, offsets_mm: dict[str, float],
                            profile: Profile) -> None:
    """An offset larger than the axis's whole travel is no joint offset of this
    machine (a hand edit, another machine's table): every target would be sent that
    far off, past the soft limits the joint coordinates were checked against."""
    low, high = profile.limits.min_mm, profile.limits.max_mm
    for axis, offset in offsets_mm.items():
        if abs(offset) > high - low:
            raise InputError(path, f"joint_offset_mm.{axis} = {offset} mm is more than the "
                             f"{axis} axis's whole travel ({high - low:g} mm, the profile's "
                             f"soft limits [{low:g}, {high:g}] mm): not an offset of this "
                             "machine; check the file (`ogacq offsets write` writes it)")


def _controller_description(spec: ControllerSpec, controller: AxisController) -> dict[str, Any]:
    out: dict[str, Any] = {"profile": spec.profile, "port": spec.port,
                           # one identity whether named or given as a file: the
                           # write-back compares the name, the checksum traces the content
                           "profile_name": controller.profile.name,
                           "profile_sha256": _file_sha256(controller.profile.source),
                           "offset_kind": controller.profile.offset.kind,
                           "reconnect": spec.reconnect.as_dict(),
                           "rehome_after_loss": spec.rehome_after_loss}
    if spec.axes:
        out["axes"] = {a: {"port": spec.port_of(a), "device_id": controller.device_ids[a]}
                       for a in controller.axes}
    if spec.baudrate is not None:  # an RTU line's rate, for a resume to reopen it
        out["baudrate"] = spec.baudrate
    if spec.offsets_file is not None:
        out["offsets_file"] = str(spec.offsets_file)
    if spec.maps_file is not None:
        out["maps_file"] = str(spec.maps_file)
    return out


def _file_sha256(path: str) -> str | None:
    """The SHA-256 of the file's bytes (None: a profile built in code, no file)."""
    try:
        return hashlib.sha256(Path(path).read_bytes()).hexdigest()
    except OSError:
        return None


def _gauge_where(gauge: GaugeSpec, specs: Sequence[GaugeSpec]) -> str:
    """How errors name what answers on the gauge's port and channel: the gauge, or the
    indicator when it serves several gauges (moved from leg to leg)."""
    channel = f" channel {gauge.channel}" if gauge.channel else ""
    shared = [s.gauge for s in specs if (s.port, s.channel) == (gauge.port, gauge.channel)]
    if shared != [gauge.gauge]:
        return f"indicator on {gauge.port}{channel}"
    return f"gauge {gauge.gauge} ({gauge.port}{channel})"


@contextlib.contextmanager
def open_gauges(specs: Sequence[GaugeSpec]) -> Iterator[dict[str, Any]]:
    """One driver per indicator, with the line settings the campaign gives (its baud
    rate over the protocol's); all closed on leaving. Gauges on one port (a
    multiplexer's channels) share one open link, since a serial port can be opened
    only once, and the gauges of one indicator moved from leg to leg share its driver."""
    links: dict[str, Any] = {}
    drivers: dict[tuple[str, str | None], Any] = {}
    indicators: dict[str, Any] = {}
    with contextlib.ExitStack() as stack:
        for g in specs:
            key = (g.port, g.channel)
            if key not in drivers:
                where = _gauge_where(g, specs)
                serial = backend(g.protocol).serial  # else a USB cable or input device
                if serial and g.port not in links:
                    settings = backend(g.protocol).settings
                    if g.baudrate is not None:
                        settings = replace(settings, baudrate=g.baudrate)
                    links[g.port] = open_link(g.port, settings, where=where)
                    stack.callback(links[g.port].close)
                drivers[key] = open_indicator(g.protocol, g.port, unit=g.unit, channel=g.channel,
                                              where=where, link=links[g.port] if serial else None)
                if not serial:  # it opened itself
                    stack.callback(drivers[key].close)
            indicators[g.gauge] = drivers[key]
        yield indicators


@contextlib.contextmanager
def open_station(campaign: Campaign, simulator: SimulatorStack | None = None,
                 ) -> Iterator[DeviceStation]:
    """Open everything the campaign names; close it all after. A ``[simulator]``
    campaign starts the built-in simulator here, unless a running one (the wizard's
    rehearsal) is given, which stays the caller's to close."""
    with contextlib.ExitStack() as stack:
        controller_spec, gauge_specs = campaign.controller, campaign.gauges
        if simulator is None and campaign.simulator is not None:
            simulator = start_simulator(campaign.machine, campaign.simulator)
            stack.callback(simulator.close)
        if simulator is not None:
            files = campaign.controller  # the tables ogacq applies, kept on the simulator's
            controller_spec, gauge_specs = simulator_endpoints(simulator)
            if files is not None:
                controller_spec = replace(controller_spec, offsets_file=files.offsets_file,
                                          maps_file=files.maps_file)
        if controller_spec is None:  # read_campaign refuses it; a Campaign made in code may not
            raise InputError(campaign.path, "missing [controller] (profile and port), or a "
                             "[simulator] table")
        controller = stack.enter_context(open_controller(controller_spec))
        # the axis scales are opened as gauges are, named scale_x beside them
        scales = simulator_scales(simulator) if simulator is not None \
            else campaign.axis_scales
        scale_specs = [s.as_gauge(a) for a, s in scales.items()]
        indicators = stack.enter_context(open_gauges([*gauge_specs, *scale_specs]))
        if simulator is not None:
            clock, speed = simulator.clock.now, simulator.clock.speed
        else:
            clock, speed = time.monotonic, 1.0
        identification = identify(controller)  # who the drives say they are, for the record
        description = {
            "controller": _controller_description(controller_spec, controller)
            | {"identification": identification},
            "gauges": {g.gauge: {"protocol": g.protocol, "port": g.port, "channel": g.channel,
                                 "unit": g.unit, "serial": g.serial}
                       # a resumed campaign (the wizard's too) reopens the gauge at this rate
                       | ({"baudrate": g.baudrate} if g.baudrate is not None else {})
                       for g in gauge_specs},
            # ogacq sim's controller says so itself, whatever the campaign file names
            "simulated": simulator is not None or simulated_by_identity(identification),
        }
        if scales:
            description["axis_scales"] = {
                a: {"protocol": s.protocol, "port": s.port, "channel": s.channel,
                    "unit": s.unit, "serial": s.serial, "resolution_mm": s.resolution_mm}
                for a, s in scales.items()}
        station = DeviceStation(controller, indicators, clock, speed, description, simulator,
                                controller_spec.reconnect,
                                rehome_after_loss=controller_spec.rehome_after_loss)
        stack.callback(station.close)  # before the gauges close (callbacks run last first)
        yield station
