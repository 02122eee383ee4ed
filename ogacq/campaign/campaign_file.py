"""Campaign files (TOML) for unattended runs: machine, station, protocol, output.

The file's schema (CAMPAIGN_FILE) both reads and writes it. Everything is
checked before anything moves: unknown keys, missing ports,
postures outside the workspace, two gauges of a leg on one port channel. Errors
name the file and the line. One indicator may serve one gauge on each leg: the
papers' two indicators, moved from leg to leg (give each of its gauges the same
port); the campaign then waits for the operator at each leg (see `ogacq run`).

    machine = "machine.toml"          # relative to this file
    operator = "J. Martin"            # who runs the calibration (recorded)
    session = "runs/cal-1.jsonl"      # where the session is written
    deadline_s = 3600                 # the most working time (moves, settling, readings;
                                      # not the operator's) a run may take; default: the
                                      # plan's steps each taking their whole timeout
    scan_minutes = 40                 # ogacq calibrate: the machine time its separating
                                      # scan may take (designed for the machine's screws)
    [controller]
    profile = "cia402"                # or "iai-pcon", "mr-je-c", "kinco-fd", or a file path
    port = "127.0.0.1:502"            # host:port (TCP) or a serial device (RTU), shared
                                      # by the three axes (told apart by device id)
    baudrate = 38400                  # RTU only
    reconnect_attempts = 5            # a dropped link: reconnects before the campaign stops,
    reconnect_backoff_s = 1.0         # the first after this wait, each next after twice it
    rehome_after_loss = true          # an axis whose drive lost its position reference (a
                                      # power cycle) is homed again unattended, then a
                                      # posture is checked against the readings on file;
                                      # false: the campaign stops (exit 3) for a person
    [controller.axes]                 # instead of `port`, or beside it: one endpoint per
                                      # axis (drives that are one Ethernet device each);
    x = { port = "192.168.3.11:502", device_id = 255 }  # device_id: Modbus unit id,
    y = { port = "192.168.3.12:502" } # 0..255 over TCP, 1..247 over RTU; the profile's
    z = { port = "192.168.3.13:502" } # when left out. An axis without `port` uses the shared one
    offsets_file = "offsets.toml"     # software offset table (profiles without an offset
                                      # register, e.g. iai-pcon): applied to every commanded
                                      # position, written by `ogacq offsets write`
    maps_file = "maps.json"           # error maps ogacq applies to every target it
                                      # commands (the drives hold no table), written by
                                      # `ogacq calibrate`
    tables = ["linuxcnc", "csv"]      # the compensation table formats `ogacq calibrate`
                                      # writes (ogacq.compensation.formats); default all
    [[gauges]]
    gauge = "y_x"                     # along y on the x leg
    protocol = "mitutoyo-01a"         # a protocol of ogacq_drivers.indicators.BACKENDS
                                      # (README: cables)
    port = "/dev/ttyUSB0"             # usb / usb:SERIAL (usb-itn); keyboard or
                                      # /dev/input/eventN (usb-itn-keyboard)
    channel = 1                       # multiplexer channel, when there is one
    unit = "mm"
    serial = "SN 1234"                # the gauge's serial number, recorded in the session
    make = "Mitutoyo"                 # identity and calibration certificate (recorded;
    model = "543-790B"                # the uncertainty budget uses U and k)
    certificate = "DKD-K-12345 2026-0412"
    calibrated = 2026-03-01           # TOML dates, unquoted
    due = 2027-03-01                  # past it, the campaign is refused before anything
                                      # moves (see [override])
    uncertainty_mm = 0.0015           # the certificate's expanded uncertainty U ...
    uncertainty_k = 2.0               # ... and its coverage factor k
    [axis_scale.x]                    # optional: a length-measuring instrument along the x
                                      # actuator (a linear scale, a long-stroke indicator) for
                                      # `ogacq positioning` and calibrate's validation
    protocol = "mitutoyo-01a"         # read as a gauge is (the same keys as [[gauges]] but
    port = "/dev/ttyUSB6"             # `gauge`); in a [simulator] campaign none of them: the
    resolution_mm = 0.001             # simulator serves it. resolution_mm: its display step
    [protocol]
    postures = ["zero", "max", "min", "zero"]
    cycles = 3
    approach = "sequence"             # sequence, from_below, from_above, both
    settle = "stable"                 # "stable": read once each gauge is at rest against
                                      # its own noise (at most settle_s); "fixed": wait
    settle_s = 1.0
    settle_window_s = 0.1             # stable: one period of the slowest ringing covered
                                      # (0.1 s: 10 Hz and faster)
    # scan_step_mm = 1.0              # a scan instead of postures: every 1 mm, up and down
    # scan_from_mm = -50.0            # the scan's range (default: rho_min..rho_max)
    # scan_to_mm = 50.0
    [stability]
    readings = 3
    tolerance_mm = 0.002
    timeout_s = 10
    [simulator]                       # instead of hardware: the built-in simulator
    seed = 3
    effects = "effects.toml"
    speed = 20
    gauge_protocol = "usb-itn"        # what the simulated gauges speak (default 01A)
    gauge_protocols = { z_y = "sylvac-simplex" }   # per gauge, over gauge_protocol
    date = 2026-01-10T09:00:00        # rehearse the campaign on this date (default: now)
    ambient_c = 20.0                  # the simulated shop's temperature (the legs expand)
    [environment]                     # recorded at the start (and the end) of the campaign
    ambient_c = 20.4                  # typed: the ambient temperature, degC
    machine_c = 21.0                  # typed: the machine's, when measured
    sensor = "controller"             # or read the controller profile's [temperature]
                                      # register(s) at the start and the end
    [override]
    expired_gauges = "reason"         # run although a gauge is past its due date; the
                                      # reason is recorded in the session
"""

from __future__ import annotations

import datetime
import re
from collections.abc import Callable
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any

from ogacq_drivers.axes.profile import Profile, ProfileError, load_profile
from ogacq_drivers.axes.reconnect import ReconnectPolicy
from ogacq_drivers.config_schema import (
    DATE,
    MOMENT,
    TRUTH,
    Field,
    FilePath,
    ListOf,
    MapOf,
    Source,
    Table,
    TableArray,
    Value,
    dump,
    number,
    text,
    text_among,
    whole,
)
from ogacq_drivers.indicators import BACKENDS, DEFAULT_PROTOCOL, same_indicator
from ogacq.compensation.formats import TABLE_FORMATS
from ogacq.io.dates import local_moment, moment_or_none
from ogacq.io.errors import InputError
from ogacq.io.machine_file import read_machine
from ogacq.io.names import name_problem
from ogacq.io.toml_file import load_toml
from ogacq.model.gauges import GAUGE_KEYS, Gauge
from ogacq.model.instrument import MAX_CERTIFICATE_U_MM, Instrument
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import AXES
from ogacq.protocol.plan import (
    APPROACHES,
    SETTLES,
    PlanError,
    ProtocolConfig,
    StabilityRule,
    check_postures,
)

# the protocols BACKENDS holds when a file is read: one registered later (a plugin, a
# test's throwaway module) is a campaign file's choice without a line here
PROTOCOL_NAME = text_among(BACKENDS.keys())
GAUGE_LAYOUTS = ("separate", "multiplexer", "moved")


@dataclass(frozen=True, kw_only=True)
class GaugeIdentity:
    """A gauge's make, model and calibration certificate (docs/calibration-record.md 1),
    beside the serial number: what a campaign file's [[gauges]] entry and the wizard's
    inventory (``ogacq.campaign.inventory``) both hold, read by ``CERTIFICATE_FIELDS``.
    Keyword-only, so each holder keeps its own positional fields first."""

    make: str = ""
    model: str = ""
    certificate: str = ""
    calibrated: datetime.date | None = None
    due: datetime.date | None = None
    uncertainty_mm: float | None = None
    uncertainty_k: float | None = None

    def identity(self) -> dict[str, Any]:
        """The serial (each holder's own field) and every identity key known (None and
        "" are not): to carry them onto another endpoint or holder."""
        keys = ("serial", *(f.name for f in fields(GaugeIdentity)))
        return {f.name: getattr(self, f.name) for f in fields(self)
                if f.name in keys and getattr(self, f.name) not in (None, "")}


@dataclass(frozen=True)
class GaugeSpec(GaugeIdentity):
    gauge: str
    protocol: str = ""  # "" only in a [simulator] campaign: the simulator's gauges
    port: str = ""
    channel: str | None = None
    unit: str = "mm"
    serial: str = ""
    baudrate: int | None = None

    def instrument(self, resolution_mm: float | None = None) -> Instrument:
        """The gauge as a traceable instrument (what the session header records)."""
        return Instrument(self.gauge, resolution_mm=resolution_mm, **self.identity())


@dataclass(frozen=True)
class AxisScaleSpec(GaugeSpec):
    """A length-measuring instrument along one actuator (``[axis_scale.x]``): a linear
    scale or a long-stroke indicator whose probe rides on the carriage, read through the
    gauge drivers as any gauge is (a gauge's keys but ``gauge``). It reads the joint's
    actual displacement along its line, up to a constant: what ISO 230-2's positioning
    test measures."""

    gauge: str = ""  # the name it is opened under: as_gauge's
    # its display step (the simulator's: 1 µm, a linear scale on a counter)
    resolution_mm: float = 0.001

    def as_gauge(self, axis: str) -> AxisScaleSpec:
        """The scale as the gauge drivers open it (``scale_x`` in messages)."""
        return replace(self, gauge=scale_name(axis))


def scale_name(axis: str) -> str:
    """How an axis scale is named where gauges are (a driver's messages, a session)."""
    return f"scale_{axis}"


ENVIRONMENT_SENSORS = ("controller",)


@dataclass(frozen=True)
class EnvironmentSpec:
    """The temperatures a campaign records at its start and its end: typed in the
    file (the same values at both ends, unless the wizard asks again) or read from
    a sensor."""

    ambient_c: float | None = None
    machine_c: float | None = None
    sensor: str | None = None  # "controller": the profile's [temperature] registers


@dataclass(frozen=True)
class AxisEndpoint:
    """Where one axis's drive answers, when it is not the shared ``port``."""

    port: str | None = None
    device_id: int | None = None


@dataclass(frozen=True)
class ControllerSpec:
    profile: str
    port: str = ""  # shared endpoint ("" when every axis has its own)
    baudrate: int | None = None
    timeout_s: float = 1.0
    # The software offset table (relative paths resolved against the campaign file);
    # None: the profile keeps its offsets in the controller, or none are applied.
    offsets_file: Path | None = None
    axes: dict[str, AxisEndpoint] = field(default_factory=dict)
    # The error maps ogacq applies to every commanded target (ogacq.writeback.maps_table);
    # None: none are applied.
    maps_file: Path | None = None
    reconnect_attempts: int = ReconnectPolicy.attempts
    reconnect_backoff_s: float = ReconnectPolicy.backoff_s
    # An axis that lost its position reference (a drive switched off and on) is homed
    # again unattended; False: the campaign stops, resumable, for someone to home it.
    rehome_after_loss: bool = True
    # The compensation table formats `calibrate` writes (None: every one registered).
    tables: tuple[str, ...] | None = None

    @property
    def reconnect(self) -> ReconnectPolicy:
        """How a dropped link is ridden out before the campaign stops."""
        return ReconnectPolicy(self.reconnect_attempts, self.reconnect_backoff_s)

    def port_of(self, axis: str) -> str:
        given = self.axes.get(axis)
        return given.port if given is not None and given.port else self.port

    def endpoints(self) -> str:
        """Where the controller answers, for messages: the shared port or one per axis."""
        if not self.axes:
            return self.port
        return ", ".join(f"{a} {self.port_of(a)}" for a in AXES)

    def device_ids(self) -> dict[str, int]:
        """Unit ids given in the campaign file (the profile's for the others)."""
        return {a: e.device_id for a, e in self.axes.items() if e.device_id is not None}


@dataclass(frozen=True)
class SimulatorSpec:
    seed: int = 0
    effects: Path | None = None
    speed: float = 20.0
    profile: str = "cia402"
    noise_mm: float | None = None
    gauge_layout: str = "separate"  # "multiplexer": six channels on one port; "moved":
    # two indicators the simulated operator moves from leg to leg
    gauge_protocol: str = DEFAULT_PROTOCOL
    gauge_protocols: tuple[tuple[str, str], ...] = ()  # (gauge, protocol) overrides
    # the campaign rehearsed on this date (None: now), in a shop at ambient_c (the
    # simulated legs expand with it)
    date: datetime.datetime | None = None
    ambient_c: float = 20.0
    # the gauges' serial lines run `speed` times faster too (each byte's time divided
    # by it, the frames still real): a rehearsal that is not about the line's timing
    line_at_speed: bool = False
    # the axes along which the simulator serves a scale (the campaign's [axis_scale.x]
    # tables, or calibrate's --axis-scales), and their display step
    axis_scales: tuple[str, ...] = ()
    scale_resolution_mm: float = AxisScaleSpec.resolution_mm

    def header(self) -> dict[str, Any]:
        """The session header's ``simulator`` entry: what a resume restarts."""
        out = {"seed": self.seed, "profile": self.profile, "speed": self.speed,
               "effects": str(self.effects or ""), "gauge_layout": self.gauge_layout,
               "gauge_protocol": self.gauge_protocol,
               "gauge_protocols": dict(self.gauge_protocols), "ambient_c": self.ambient_c}
        if self.date is not None:  # a rehearsed date, not the calendar's
            out.update(date=self.date.isoformat(), simulated_date=True)
        if self.line_at_speed:
            out.update(line_at_speed=True)
        if self.axis_scales:
            out.update(axis_scales=list(self.axis_scales),
                       scale_resolution_mm=self.scale_resolution_mm)
        return out

    @classmethod
    def from_header(cls, entry: dict[str, Any]) -> SimulatorSpec:
        """The spec ``header`` wrote: each key read as its field's default is typed, but
        these (noise_mm is not written: a resumed simulator's noise is its seed's)."""
        read: dict[str, Callable[[Any], Any]] = {
            "effects": lambda path: Path(path) if path else None, "date": moment_or_none,
            "gauge_protocols": lambda given: tuple(sorted(given.items()))}
        return cls(**{f.name: read.get(f.name, type(f.default))(entry[f.name])
                      for f in fields(cls) if f.name in entry and f.name != "noise_mm"})


@dataclass
class Campaign:
    path: Path
    machine: MachineSpec
    machine_path: Path
    session: Path
    protocol: ProtocolConfig
    controller: ControllerSpec | None = None
    gauges: list[GaugeSpec] = field(default_factory=list)
    simulator: SimulatorSpec | None = None
    deadline_s: float | None = None  # None: derived from the plan (ogacq.protocol.deadline)
    operator: str = ""
    environment: EnvironmentSpec | None = None
    override_expired: str = ""  # the reason to run with a gauge past its due date
    scan_minutes: float | None = None  # calibrate's separating scan budget (None: default)
    # gauges identified without a [[gauges]] entry (the wizard's, read by eye)
    extra_instruments: list[Instrument] = field(default_factory=list)
    # [axis_scale.x]: a length-measuring instrument along an actuator, per axis
    axis_scales: dict[str, AxisScaleSpec] = field(default_factory=dict)

    def campaign_date(self) -> datetime.datetime:
        """The campaign's date: the simulator's rehearsed one, or now (local time)."""
        if self.simulator is not None and self.simulator.date is not None:
            return self.simulator.date
        return datetime.datetime.now().replace(microsecond=0)

    def instruments(self, resolution_mm: float | None = None) -> list[Instrument]:
        """The [[gauges]] entries as instruments, in the file's order, then the
        instruments identified otherwise."""
        return [g.instrument(resolution_mm) for g in self.gauges] + [
            replace(i, resolution_mm=resolution_mm) for i in self.extra_instruments]

    @property
    def moved_indicators(self) -> dict[str, list[str]]:
        """Indicators that serve a gauge on several legs (moved from leg to leg):
        where each is connected -> its gauges. Empty when every gauge stays put."""
        by_link: dict[str, list[str]] = {}
        for g in self.gauges:
            if not g.port:
                continue  # a simulator's gauge, identified only
            where = g.port + (f" channel {g.channel}" if g.channel else "")
            by_link.setdefault(where, []).append(g.gauge)
        return {where: gauges for where, gauges in by_link.items() if len(gauges) > 1}


# --------------------------------------------------------------------------- the schema
# Durations, counts, speeds and tolerances cannot be negative (a negative settle time
# would fail only after homing); a timeout of zero never lets anything answer. Nor
# can they be astronomical: each has a maximum an order of magnitude beyond any
# campaign's (no source; a larger value is a typo, and 1e308 s would overflow a sleep).
HOUR_S = 3600.0
_TIMEOUT = number(minimum=1e-3, maximum=HOUR_S)
_BAUDRATE = whole(minimum=1, maximum=10_000_000)  # RS-485 runs up to 10 Mbit/s
_LENGTH_MM = 10_000.0  # 10 m: beyond any leg (the machine file's own bound is 100 m)

_AXIS_ENDPOINT = Table((
    Field("port", text()),
    # Modbus unit id: 0..255 over TCP (1..247 over RTU, checked with the port below)
    Field("device_id", whole(minimum=0, maximum=255)),
), build=AxisEndpoint)

_CONTROLLER = Table((
    Field("profile", text(), required=True),
    Field("port", text()),
    Field("baudrate", _BAUDRATE),
    Field("timeout_s", _TIMEOUT),
    Field("offsets_file", FilePath(), decode=Path.resolve),
    Field("maps_file", FilePath(), decode=Path.resolve),
    Field("axes", MapOf(_AXIS_ENDPOINT, keys=AXES, noun="axis")),
    # a reconnect policy still bounded in practice
    Field("reconnect_attempts", whole(minimum=0, maximum=100)),
    Field("reconnect_backoff_s", number(minimum=0.0, maximum=HOUR_S)),
    Field("rehome_after_loss", TRUTH),
    # the formats TABLE_FORMATS holds when a file is read (a format registered later is
    # a choice too)
    Field("tables", ListOf(text_among(TABLE_FORMATS.keys())), decode=tuple, encode=list),
), build=ControllerSpec)

# A temperature a shop floor may have: beyond it, a typo (a Fahrenheit value, a sign)
_TEMPERATURE = number(minimum=-40.0, maximum=80.0)

# A gauge's identity and calibration certificate, as a campaign file and the wizard's
# instruments inventory both write them (docs/calibration-record.md 1).
CERTIFICATE_FIELDS = (
    Field("make", text()),
    Field("model", text()),
    Field("certificate", text()),
    Field("calibrated", DATE),
    Field("due", DATE),
    # the certificate's U and k: a U of 0 would claim a perfect gauge
    Field("uncertainty_mm", number(positive=True, maximum=10.0)),
    Field("uncertainty_k", number(minimum=1.0, maximum=10.0)),
)

# How a gauge or an axis scale is read: protocol and port required without [simulator]
# (checked with the file's line in _gauges and _axis_scales); unit as set on its display
_READ_AS = (
    Field("protocol", PROTOCOL_NAME),
    Field("port", text()),
    Field("channel", Value((str, int)), decode=str),
    Field("unit", text("mm", "inch")),
    Field("serial", text()),
    Field("baudrate", _BAUDRATE),
)

_GAUGE = Table((
    Field("gauge", text(*GAUGE_KEYS), required=True),  # AXIS_LEG: along AXIS on that leg
    *_READ_AS,
    *CERTIFICATE_FIELDS,
), build=GaugeSpec)

_AXIS_SCALE = Table((
    *_READ_AS,
    # a display step of 1 µm to 0.1 mm: the gauge drivers read a mm display of one to
    # three decimals (drivers/indicators/base.py DEFAULT_DECIMALS: four would pass for
    # an inch display); beyond 0.1 mm, a unit slip (no source)
    Field("resolution_mm", number(minimum=0.001, maximum=0.1)),
    *CERTIFICATE_FIELDS,
), build=AxisScaleSpec)

_ENVIRONMENT = Table((
    Field("ambient_c", _TEMPERATURE),
    Field("machine_c", _TEMPERATURE),
    Field("sensor", text(*ENVIRONMENT_SENSORS)),
), build=EnvironmentSpec)

_OVERRIDE = Table((
    Field("expired_gauges", text()),
))

_PROTOCOL = Table((
    Field("legs", ListOf(text(*AXES))),
    Field("postures", ListOf(Value((str, float)))),  # zero, max, min or a q in mm
    Field("cycles", whole(minimum=1, maximum=1000)),
    Field("approach", text(*APPROACHES)),
    Field("overshoot_mm", number(minimum=0.0, maximum=_LENGTH_MM)),
    Field("settle", text(*SETTLES)),
    Field("settle_s", number(minimum=0.0, maximum=HOUR_S)),
    Field("settle_window_s", number(positive=True, maximum=HOUR_S)),
    Field("move_timeout_s", _TIMEOUT),
    Field("scan_step_mm", number(positive=True, maximum=_LENGTH_MM)),
    Field("scan_from_mm", number(minimum=-_LENGTH_MM, maximum=_LENGTH_MM)),
    Field("scan_to_mm", number(minimum=-_LENGTH_MM, maximum=_LENGTH_MM)),
    # a designed scan's targets (ogacq.protocol.scan_design), as ogacq calibrate runs it
    Field("scan_targets_mm", ListOf(number(minimum=-_LENGTH_MM, maximum=_LENGTH_MM))),
))

_STABILITY = Table((
    Field("readings", whole(minimum=1, maximum=1000)),
    Field("tolerance_mm", number(minimum=0.0, maximum=_LENGTH_MM)),
    Field("timeout_s", _TIMEOUT),
))

_SIMULATOR = Table((
    Field("seed", whole(minimum=0)),
    Field("effects", FilePath()),
    Field("speed", number(minimum=1e-3, maximum=1e6)),
    Field("profile", text()),
    Field("noise_mm", number(minimum=0.0, maximum=1.0)),  # 1 mm: beyond any indicator
    Field("gauge_layout", text(*GAUGE_LAYOUTS)),
    Field("gauge_protocol", PROTOCOL_NAME),
    Field("gauge_protocols", MapOf(PROTOCOL_NAME, keys=GAUGE_KEYS, noun="gauge"),
          decode=lambda table: tuple(sorted(table.items())), encode=dict),
    Field("date", MOMENT, decode=moment_or_none),
    Field("ambient_c", _TEMPERATURE),
    Field("line_at_speed", TRUTH),
), build=SimulatorSpec)

CAMPAIGN_FILE = Table((
    Field("machine", FilePath(), required=True),
    Field("operator", text()),
    Field("session", FilePath()),
    Field("deadline_s", number(minimum=1.0, maximum=1000 * HOUR_S)),
    # the machine time ogacq calibrate's designed separating scan may take
    Field("scan_minutes", number(positive=True, maximum=1000 * 60.0)),
    Field("controller", _CONTROLLER),
    Field("gauges", TableArray(_GAUGE)),
    Field("axis_scale", MapOf(_AXIS_SCALE, keys=AXES, noun="axis"), attr="axis_scales"),
    Field("protocol", _PROTOCOL),
    Field("stability", _STABILITY),
    Field("simulator", _SIMULATOR),
    Field("environment", _ENVIRONMENT),
    Field("override", _OVERRIDE),
))


# --------------------------------------------------------------------------- reading


def read_campaign(path: str | Path) -> Campaign:
    path = Path(path)
    given, src = load_toml(path, CAMPAIGN_FILE, "the campaign file")
    machine = read_machine(given["machine"])
    protocol = _protocol(src, given.get("protocol", {}), given.get("stability", {}), machine)
    campaign = Campaign(path, machine, given["machine"],
                        given.get("session", path.parent / f"sessions/{path.stem}.jsonl"),
                        protocol, simulator=given.get("simulator"),
                        deadline_s=given.get("deadline_s"),
                        scan_minutes=given.get("scan_minutes"),
                        operator=given.get("operator", "").strip(),
                        environment=given.get("environment"))
    operator_problem = name_problem(campaign.operator)
    if operator_problem is not None:  # recorded, printed and filed as a name is
        raise src.fail(("operator",), f"= {campaign.operator[:60]!r} {operator_problem}")
    override = given.get("override", {}).get("expired_gauges")
    if override is not None:
        if not override.strip():
            raise src.fail(("override", "expired_gauges"), "", "override.expired_gauges needs "
                           "a reason (what makes the measurement valid all the same)")
        campaign.override_expired = override.strip()
    if campaign.simulator is not None:
        _check_profile(src, ("simulator", "profile"), campaign.simulator.profile)
        if campaign.simulator.date is not None:  # the shop's wall time, as `now` is taken
            local_moment(campaign.simulator.date, source=path, key="simulator.date",
                         line=src.line(("simulator", "date")))
    if campaign.simulator is not None and campaign.simulator.gauge_layout == "multiplexer" \
            and (campaign.simulator.gauge_protocol != DEFAULT_PROTOCOL
                 or campaign.simulator.gauge_protocols):
        raise src.fail(("simulator", "gauge_layout"), "", "a simulated multiplexer is an 01A "
                       "box: gauge_protocol(s) do not apply with gauge_layout = \"multiplexer\"")
    if campaign.simulator is not None:
        _check_simulated_only(src, given)
    if "controller" in given:
        campaign.controller = _controller(src, given["controller"])
    elif campaign.simulator is None:
        raise src.fail((), "missing [controller] (profile and port), or a [simulator] table")
    campaign.gauges = _gauges(src, given.get("gauges", []),
                              simulated=campaign.simulator is not None)
    campaign.axis_scales = _axis_scales(src, given.get("axis_scales", {}), campaign)
    _check_environment(src, campaign)
    if campaign.simulator is None:
        wanted = {f"{a}_{leg}" for leg in protocol.legs for a in "xyz" if a != leg}
        missing = sorted(wanted - {g.gauge for g in campaign.gauges})
        if missing:
            raise src.fail((), f"no [[gauges]] entry for {', '.join(missing)}: an unattended "
                           "campaign needs both gauges of every leg mounted")
    return campaign


def _protocol(src: Source, given: dict, stability: dict, machine: MachineSpec,
              ) -> ProtocolConfig:
    if "postures" in given and "scan_step_mm" in given:
        raise src.fail(("protocol", "postures"), "", "postures and scan_step_mm exclude each "
                       "other: a scan's postures are every scan_step_mm along the travel")
    scan_range = [k for k in ("scan_from_mm", "scan_to_mm") if k in given]
    if scan_range and "scan_step_mm" not in given:
        raise src.fail(("protocol", scan_range[0]), "", f"{scan_range[0]} needs scan_step_mm "
                       "(the step of the scan)")
    try:
        config = ProtocolConfig(stability=StabilityRule(**stability), **given)
        check_postures(config, machine)
    except PlanError as exc:
        key = next((k for k in ("scan_targets_mm", "scan_step_mm", "scan_from_mm",
                                "scan_to_mm", "postures",
                                "approach", "cycles", "legs", "overshoot_mm")
                    if k in str(exc) or k.rstrip("s") in str(exc)), "postures")
        raise src.fail(("protocol", key), "", str(exc)) from None
    return config


def _check_simulated_only(src: Source, given: dict) -> None:
    """Real or simulated, said once: a [simulator] campaign names no real controller
    and no gauge port (gauges there carry identities only), else it would run on the
    simulator while the file says where the machine is."""
    real = []
    if "controller" in given:
        spec: ControllerSpec = given["controller"]
        real.append(f"[controller] {spec.endpoints() or spec.profile}")
    real += [f"gauge {g.gauge} on {g.port or g.protocol}" for g in given.get("gauges", [])
             if g.port or g.protocol]
    real += [f"{a} axis scale on {s.port or s.protocol}"
             for a, s in given.get("axis_scales", {}).items() if s.port or s.protocol]
    if real:
        raise src.fail(("simulator",), "", f"a [simulator] table and real ports "
                       f"({', '.join(real[:3])}{', ...' if len(real) > 3 else ''}): a campaign "
                       "runs on the simulator or on the machine; remove [simulator] to run on "
                       "the machine, or the ports to rehearse")


def _controller(src: Source, spec: ControllerSpec) -> ControllerSpec:
    if not spec.port and not all(a in spec.axes and spec.axes[a].port for a in AXES):
        raise src.fail(("controller",), "", "[controller] needs 'port', or a port for each of "
                       "x, y and z in [controller.axes]")
    profile = _check_profile(src, ("controller", "profile"), spec.profile)
    kind = profile.offset.kind
    if spec.offsets_file is not None and kind != "software":
        raise src.fail(("controller", "offsets_file"), "", f"offsets_file: profile "
                       f"{spec.profile!r} keeps the joint offsets in the controller ({kind}); "
                       "a software offset table does not apply")
    _check_unit_ids(src, spec, profile.device_ids)
    _check_tcp_ports(src, spec)
    return spec


def is_modbus_tcp(where: str) -> bool:
    """A controller endpoint ``host:port`` is Modbus TCP; anything else is a serial
    device (Modbus RTU, which needs a baud rate)."""
    _, sep, port = where.rpartition(":")
    return bool(sep) and port.isdigit() and not where.startswith("/")


_IPV4 = re.compile(r"[0-9]{1,3}(\.[0-9]{1,3}){3}")


def _check_tcp_ports(src: Source, spec: ControllerSpec) -> None:
    """An endpoint that cannot be one: a TCP port beyond 16 bits (RFC 793 3.1: ports
    0..65535), or an IP address without its port (read as a serial device, it failed
    as "cannot connect", exit 3, for a slip of the file's). 502 is Modbus TCP's port
    (IANA's port registry: 502/tcp "mbap", Modbus Application Protocol)."""
    where: list[tuple[tuple[str, ...], str]] = (
        [(("controller", "port"), spec.port)] if spec.port else [])
    where += [(("controller", "axes", a, "port"), e.port) for a, e in spec.axes.items() if e.port]
    for key, port in where:
        number = port.rpartition(":")[2]
        if is_modbus_tcp(port) and int(number) > 65535:
            raise src.fail(key, "", f"port {port!r}: TCP port {number} is beyond 65535 "
                           "(Modbus TCP's is 502)")
        if _IPV4.fullmatch(port.strip()):
            raise src.fail(key, "", f"port {port!r} is an IP address without its port: Modbus "
                           f"TCP is host:port ({port.strip()}:502 for Modbus's own port)")


def _check_profile(src: Source, key: tuple[str, ...], name: str) -> Profile:
    """The register map ``name`` names, loaded now: a wrong name or a broken profile
    file is said with the campaign file's line, before anything opens."""
    try:
        return load_profile(name)
    except ProfileError as exc:
        raise src.fail(key, "", f"profile {name!r}: {exc}") from None


def _check_unit_ids(src: Source, spec: ControllerSpec, profile_ids: dict[str, int]) -> None:
    """A serial (RTU) endpoint addresses units 1..247 only (Modbus over Serial Line
    V1.02 §2.2); TCP takes 0..255."""
    ids = {**profile_ids, **spec.device_ids()}
    for axis, unit in ids.items():
        port = spec.port_of(axis)
        if not is_modbus_tcp(port) and not 1 <= unit <= 247:
            raise src.fail(("controller", "axes" if spec.axes else "profile"), "",
                           f"axis {axis}: device id {unit} cannot be addressed over Modbus RTU "
                           f"on {port} (1..247); set controller.axes.{axis}.device_id")


def _check_environment(src: Source, campaign: Campaign) -> None:
    """A temperature sensor named must exist: the controller profile's registers."""
    env = campaign.environment
    if env is None or env.sensor != "controller":
        return
    profile_name = (campaign.simulator.profile if campaign.simulator is not None
                    else campaign.controller.profile if campaign.controller else "")
    profile = _check_profile(src, ("environment", "sensor"), profile_name)
    if profile.temperature is None:
        raise src.fail(("environment", "sensor"), "", f"environment.sensor = \"controller\": "
                       f"profile {profile_name!r} has no [temperature] register; type the "
                       "temperatures (ambient_c, machine_c) instead")


def _check_entry(src: Source, at: tuple[str | int, ...], g: GaugeSpec, *,
                 simulated: bool) -> None:
    """A gauge's (or an axis scale's, at its table ``at``) identity names
    (``ogacq.io.names``: recorded and printed as a name is); a certificate's dates in
    order; its link unless simulated (_check_simulated_only refused one there)."""
    name = f"the {at[-1]} axis scale" if isinstance(g, AxisScaleSpec) else f"gauge {g.gauge}"
    for key in ("make", "model", "serial", "certificate"):
        problem = name_problem(getattr(g, key))
        if problem is not None:
            raise src.fail((*at, key), f"= {getattr(g, key)[:60]!r} {problem}")
    if g.calibrated is not None and g.due is not None and g.due <= g.calibrated:
        raise src.fail((*at, "due"), "", f"{name}: due {g.due.isoformat()} "
                       f"is not after calibrated {g.calibrated.isoformat()}")
    if g.uncertainty_k is not None and g.uncertainty_mm is None:
        raise src.fail((*at, "uncertainty_k"), "", f"{name}: uncertainty_k "
                       "without uncertainty_mm (the certificate's U)")
    if g.uncertainty_mm is not None and g.uncertainty_mm > MAX_CERTIFICATE_U_MM:
        raise src.fail((*at, "uncertainty_mm"), "", f"{name}: uncertainty_mm = "
                       f"{g.uncertainty_mm:g} mm is more than an indicator's certificate "
                       f"states (at most {MAX_CERTIFICATE_U_MM:g} mm): micrometres written as "
                       "mm?")
    if not simulated and (not g.protocol or not g.port):
        missing = "protocol" if not g.protocol else "port"
        raise src.fail(at, "", f"{name} needs {missing!r} (how and where it is read)")


def _gauges(src: Source, gauges: list[GaugeSpec], *, simulated: bool = False,
            ) -> list[GaugeSpec]:
    """Each gauge once, with its link unless simulated; the two gauges of a leg on
    their own port or channel; one protocol per port."""
    seen: dict[str, int | None] = {}
    for k, g in enumerate(gauges):
        line = src.line(("gauges", k))
        if g.gauge in seen:
            raise InputError(src.path, f"gauge {g.gauge} appears twice (first on line "
                             f"{seen[g.gauge]})", line)
        _check_entry(src, ("gauges", k), g, simulated=simulated)
        if simulated:
            seen[g.gauge] = line  # the simulator's gauge, identified here
            continue
        _check_own_indicator(src, g, gauges[:k], seen, line)
        first_on_port = next((other for other in gauges[:k] if other.port == g.port), None)
        if first_on_port is not None and first_on_port.protocol != g.protocol:
            raise InputError(src.path, f"gauge {g.gauge} on port {g.port} is {g.protocol} but "
                             f"{first_on_port.gauge} on the same port is "
                             f"{first_on_port.protocol}: one port speaks one protocol", line)
        seen[g.gauge] = line
    return gauges


def _axis_scales(src: Source, scales: dict[str, AxisScaleSpec], campaign: Campaign,
                 ) -> dict[str, AxisScaleSpec]:
    """Each scale with its link (on a station) or none (the simulator serves it, and is
    told which axes); a scale's port not a leg gauge's."""
    for axis, scale in scales.items():
        _check_entry(src, ("axis_scale", axis), scale, simulated=campaign.simulator is not None)
        if campaign.simulator is not None:
            continue
        shared = next((g.gauge for g in campaign.gauges
                       if (g.port, g.channel) == (scale.port, scale.channel)), None)
        if shared is not None:
            raise src.fail(("axis_scale", axis, "port"), "", f"the {axis} axis scale is on "
                           f"{scale.port} as gauge {shared} is: each is read on its own port "
                           "or channel")
    if campaign.simulator is not None and scales:
        campaign.simulator = replace(campaign.simulator, axis_scales=tuple(sorted(scales)))
        steps = {s.resolution_mm for s in scales.values()}
        if len(steps) == 1:
            campaign.simulator = replace(campaign.simulator, scale_resolution_mm=steps.pop())
    return scales


def _check_own_indicator(src: Source, g: GaugeSpec, before: list[GaugeSpec],
                         seen: dict[str, int | None], line: int | None) -> None:
    """Refuse a gauge read by the same indicator as an earlier gauge of its leg: the two
    gauges of a leg are read at once."""
    leg = Gauge.parse(g.gauge).leg
    # by what the driver asks for, not by spelling: 01A's unset channel is channel 1
    same_leg = [other for other in before
                if other.port == g.port and other.protocol == g.protocol
                and same_indicator(g.protocol, other.channel, g.channel)
                and Gauge.parse(other.gauge).leg == leg]
    if not same_leg:
        return
    other = same_leg[0]
    where = f"port {g.port}" + (f" channel {g.channel}" if g.channel else "")
    if other.channel != g.channel:
        where += (f" (channel {other.channel or 'not set'} and "
                  f"{g.channel or 'not set'} read the same {g.protocol} indicator)")
    raise InputError(src.path, f"gauges {other.gauge} (line {seen[other.gauge]}) and "
                     f"{g.gauge} of the {leg} leg both on {where}: the two gauges of a "
                     "leg each need their own port or channel (one indicator may serve "
                     "one gauge per leg, moved from leg to leg)", line)


# --------------------------------------------------------------------------- writing


def campaign_text(campaign: Campaign, *, comment: str = "",
                  notes: dict[str, str] | None = None) -> str:
    """The campaign file of ``campaign`` (paths relative to its folder): what
    ``read_campaign`` reads back as the same campaign. ``comment`` goes on top,
    ``notes`` (by table name) above their tables."""
    plan = campaign.protocol.to_dict()
    stability = plan.pop("stability")
    document = {"machine": campaign.machine_path, "operator": campaign.operator or None,
                "session": campaign.session, "deadline_s": campaign.deadline_s,
                "scan_minutes": campaign.scan_minutes, "simulator": campaign.simulator,
                "controller": campaign.controller,
                "gauges": campaign.gauges, "axis_scales": campaign.axis_scales or None,
                "protocol": plan, "stability": stability,
                "environment": campaign.environment,
                "override": ({"expired_gauges": campaign.override_expired}
                             if campaign.override_expired else None)}
    return dump(CAMPAIGN_FILE, document, folder=campaign.path.parent, header=comment,
                notes=notes)
