"""Campaign files (TOML) for unattended runs: machine, station, protocol, output.

Everything is checked before anything moves: unknown keys, missing ports,
postures outside the workspace, two gauges of a leg on one port channel. Errors
name the file and the line. One indicator may serve one gauge on each leg: the
papers' two indicators, moved from leg to leg (give each of its gauges the same
port); the campaign then waits for the operator at each leg (see `ogacq run`).

    machine = "machine.toml"          # relative to this file
    session = "runs/cal-1.jsonl"      # where the session is written
    deadline_s = 3600                 # the most working time (moves, settling, readings;
                                      # not the operator's) a run may take; default: the
                                      # plan's steps each taking their whole timeout
    [controller]
    profile = "cia402"                # or "iai-pcon", "mr-je-c", "kinco-fd", or a file path
    port = "127.0.0.1:502"            # host:port (TCP) or a serial device (RTU), shared
                                      # by the three axes (told apart by device id)
    baudrate = 38400                  # RTU only
    reconnect_attempts = 5            # a dropped link: reconnects before the campaign stops,
    reconnect_backoff_s = 1.0         # the first after this wait, each next after twice it
    [controller.axes]                 # instead of `port`, or beside it: one endpoint per
                                      # axis (drives that are one Ethernet device each);
    x = { port = "192.168.3.11:502", device_id = 255 }  # device_id: Modbus unit id,
    y = { port = "192.168.3.12:502" } # 0..255 over TCP, 1..247 over RTU; the profile's
    z = { port = "192.168.3.13:502" } # when left out. An axis without `port` uses the shared one
    offsets_file = "offsets.toml"     # software offset table (profiles without an offset
                                      # register, e.g. iai-pcon): applied to every commanded
                                      # position, written by `ogacq offsets write`
    [[gauges]]
    gauge = "y_x"                     # along y on the x leg
    protocol = "mitutoyo-01a"         # or digimatic, uwave, sylvac, sylvac-simplex,
                                      # usb-itn, usb-itn-keyboard (README: cables)
    port = "/dev/ttyUSB0"             # usb / usb:SERIAL (usb-itn); keyboard or
                                      # /dev/input/eventN (usb-itn-keyboard)
    channel = 1                       # multiplexer channel, when there is one
    unit = "mm"
    serial = "SN 1234"                # recorded in the session
    [protocol]
    postures = ["zero", "max", "min", "zero"]
    cycles = 3
    approach = "sequence"             # sequence, from_below, from_above, both
    settle_s = 1.0
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
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from drivers.axes.reconnect import ReconnectPolicy
from drivers.indicators import BACKENDS
from ogacq.io.errors import InputError
from ogacq.io.machine_file import read_machine
from ogacq.io.toml_file import line_of, read_toml
from ogacq.model.gauges import GAUGE_KEYS, Gauge
from ogacq.model.machine import MachineSpec
from ogacq.protocol.plan import ProtocolConfig, StabilityRule, check_postures

PROTOCOLS = tuple(BACKENDS)

_TOP = {"machine", "session", "deadline_s", "controller", "gauges", "protocol", "stability",
        "simulator"}
_CONTROLLER = {"profile", "port", "baudrate", "timeout_s", "offsets_file", "axes",
               "reconnect_attempts", "reconnect_backoff_s"}
_CONTROLLER_AXIS = {"port", "device_id"}
_GAUGE = {"gauge", "protocol", "port", "channel", "unit", "serial", "baudrate"}
_PROTOCOL = {"legs", "postures", "cycles", "approach", "overshoot_mm", "settle_s",
             "move_timeout_s"}
_STABILITY = {"readings", "tolerance_mm", "timeout_s"}
_SIMULATOR = {"seed", "effects", "speed", "profile", "noise_mm", "gauge_layout",
              "gauge_protocol", "gauge_protocols"}


@dataclass(frozen=True)
class GaugeSpec:
    gauge: str
    protocol: str
    port: str
    channel: str | None = None
    unit: str = "mm"
    serial: str = ""
    baudrate: int | None = None


@dataclass(frozen=True)
class AxisEndpoint:
    """Where one axis's drive answers, when it is not the shared ``port``."""

    port: str | None = None
    device_id: int | None = None


@dataclass(frozen=True)
class ControllerSpec:
    profile: str
    port: str  # shared endpoint ("" when every axis has its own)
    baudrate: int | None = None
    timeout_s: float = 1.0
    # The software offset table (relative paths resolved against the campaign file);
    # None: the profile keeps its offsets in the controller, or none are applied.
    offsets_file: Path | None = None
    axes: dict[str, AxisEndpoint] = field(default_factory=dict)
    reconnect: ReconnectPolicy = field(default_factory=ReconnectPolicy)

    def port_of(self, axis: str) -> str:
        given = self.axes.get(axis)
        return given.port if given is not None and given.port else self.port

    def endpoints(self) -> str:
        """Where the controller answers, for messages: the shared port or one per axis."""
        if not self.axes:
            return self.port
        return ", ".join(f"{a} {self.port_of(a)}" for a in ("x", "y", "z"))

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
    gauge_protocol: str = "mitutoyo-01a"
    gauge_protocols: tuple[tuple[str, str], ...] = ()  # (gauge, protocol) overrides

    def header(self) -> dict[str, Any]:
        """The session header's ``simulator`` entry: what a resume restarts."""
        return {"seed": self.seed, "profile": self.profile, "speed": self.speed,
                "effects": str(self.effects or ""), "gauge_layout": self.gauge_layout,
                "gauge_protocol": self.gauge_protocol,
                "gauge_protocols": dict(self.gauge_protocols)}

    @classmethod
    def from_header(cls, entry: dict[str, Any]) -> SimulatorSpec:
        return cls(seed=int(entry.get("seed", 0)),
                   effects=Path(entry["effects"]) if entry.get("effects") else None,
                   speed=float(entry.get("speed", 20.0)),
                   profile=str(entry.get("profile", "cia402")),
                   gauge_layout=str(entry.get("gauge_layout", "separate")),
                   gauge_protocol=str(entry.get("gauge_protocol", "mitutoyo-01a")),
                   gauge_protocols=tuple(sorted(entry.get("gauge_protocols", {}).items())))


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

    @property
    def moved_indicators(self) -> dict[str, list[str]]:
        """Indicators that serve a gauge on several legs (moved from leg to leg):
        where each is connected -> its gauges. Empty when every gauge stays put."""
        by_link: dict[str, list[str]] = {}
        for g in self.gauges:
            where = g.port + (f" channel {g.channel}" if g.channel else "")
            by_link.setdefault(where, []).append(g.gauge)
        return {where: gauges for where, gauges in by_link.items() if len(gauges) > 1}


class _Source:
    """The campaign file's text, to say on which line a key stands."""

    def __init__(self, path: Path, text: str) -> None:
        self.path = path
        self.text = text
        self.lines = text.splitlines()

    def line(self, key: str, after: int = 0) -> int | None:
        return line_of(self.text, key, after)

    def fail(self, problem: str, key: str | None = None, after: int = 0) -> InputError:
        return InputError(self.path, problem, self.line(key, after) if key else None)


def _table_lines(src: _Source, name: str) -> list[int]:
    return [n for n, line in enumerate(src.lines, 1) if re.match(rf"\s*\[\[{name}\]\]", line)]


def _check_keys(src: _Source, table: dict, allowed: set[str], where: str, after: int = 0) -> None:
    for key in table:
        if key not in allowed:
            raise src.fail(f"unknown key {key!r} in {where} (allowed: "
                           f"{', '.join(sorted(allowed))})", key, after)


# The smallest value each numeric key may take: durations, counts, speeds and
# tolerances cannot be negative (a negative settle time fails only after homing).
_AT_LEAST = {"settle_s": 0.0, "move_timeout_s": 1e-3, "timeout_s": 1e-3, "cycles": 1,
             "readings": 1, "tolerance_mm": 0.0, "overshoot_mm": 0.0, "speed": 1e-3,
             "seed": 0, "baudrate": 1, "deadline_s": 1.0, "reconnect_attempts": 0,
             "reconnect_backoff_s": 0.0}
# and the largest: a reconnect policy still bounded in practice
_AT_MOST = {"reconnect_attempts": 100}


def _typed(src: _Source, table: dict, key: str, kind: type | tuple, where: str,
           after: int = 0) -> Any:
    value = table[key]
    if isinstance(value, bool) and bool not in (kind if isinstance(kind, tuple) else (kind,)):
        raise src.fail(f"{where}.{key} must be {_kind_name(kind)}, got {value!r}", key, after)
    if not isinstance(value, kind):
        raise src.fail(f"{where}.{key} must be {_kind_name(kind)}, got {value!r}", key, after)
    if isinstance(value, float) and not math.isfinite(value):
        raise src.fail(f"{where}.{key} must be a finite number, got {value!r}", key, after)
    if isinstance(value, int | float) and not isinstance(value, bool) and \
            value < _AT_LEAST.get(key, -math.inf):
        raise src.fail(f"{where}.{key} must be at least {_AT_LEAST[key]:g}, got {value!r}", key,
                       after)
    if isinstance(value, int | float) and value > _AT_MOST.get(key, math.inf):
        raise src.fail(f"{where}.{key} must be at most {_AT_MOST[key]:g}, got {value!r}", key,
                       after)
    return value


def _kind_name(kind: type | tuple) -> str:
    kinds = kind if isinstance(kind, tuple) else (kind,)
    return " or ".join({int: "a whole number", float: "a number", str: "text",
                        list: "a list"}.get(k, k.__name__) for k in kinds)


def read_campaign(path: str | Path) -> Campaign:
    path = Path(path)
    try:
        data, text = read_toml(path, "campaign file")
    except FileNotFoundError:
        raise InputError(path, "no such campaign file") from None
    src = _Source(path, text)
    _check_keys(src, data, _TOP, "the campaign file")
    base = path.parent

    if "machine" not in data:
        raise src.fail("missing key 'machine' (the machine file)")
    machine_path = base / _typed(src, data, "machine", str, "campaign")
    machine = read_machine(machine_path)
    session = base / (_typed(src, data, "session", str, "campaign") if "session" in data
                      else f"sessions/{path.stem}.jsonl")

    proto = data.get("protocol", {})
    _check_keys(src, proto, _PROTOCOL, "[protocol]", src.line("protocol") or 0)
    stab = data.get("stability", {})
    _check_keys(src, stab, _STABILITY, "[stability]", src.line("stability") or 0)
    protocol = _protocol(src, proto, stab, machine)

    campaign = Campaign(path, machine, machine_path, session, protocol)
    if "deadline_s" in data:
        campaign.deadline_s = float(_typed(src, data, "deadline_s", (int, float), "campaign"))
    if "simulator" in data:
        sim = data["simulator"]
        after = src.line("simulator") or 0
        _check_keys(src, sim, _SIMULATOR, "[simulator]", after)
        effects = sim.get("effects")
        campaign.simulator = SimulatorSpec(
            seed=int(_typed(src, sim, "seed", int, "simulator", after)) if "seed" in sim else 0,
            effects=base / effects if effects else None,
            speed=float(_typed(src, sim, "speed", (int, float), "simulator", after))
            if "speed" in sim else 20.0,
            profile=str(sim.get("profile", "cia402")),
            noise_mm=float(sim["noise_mm"]) if "noise_mm" in sim else None,
            gauge_layout=_choice(src, sim, "gauge_layout", ("separate", "multiplexer", "moved"),
                                 "simulator", after),
            gauge_protocol=_choice(src, sim, "gauge_protocol", PROTOCOLS, "simulator", after),
            gauge_protocols=_sim_protocols(src, sim, after))
        if campaign.simulator.gauge_layout == "multiplexer" and (
                "gauge_protocol" in sim or "gauge_protocols" in sim):
            raise src.fail("a simulated multiplexer is an 01A box: gauge_protocol(s) do not "
                           "apply with gauge_layout = \"multiplexer\"", "gauge_layout", after)
    if "controller" in data:
        campaign.controller = _controller(src, data["controller"], base)
    elif campaign.simulator is None:
        raise src.fail("missing [controller] (profile and port), or a [simulator] table")
    campaign.gauges = _gauges(src, data.get("gauges", []), protocol)
    if campaign.simulator is None:
        wanted = {f"{a}_{leg}" for leg in protocol.legs for a in "xyz" if a != leg}
        missing = sorted(wanted - {g.gauge for g in campaign.gauges})
        if missing:
            raise src.fail(f"no [[gauges]] entry for {', '.join(missing)}: an unattended "
                           "campaign needs both gauges of every leg mounted")
    return campaign


def _sim_protocols(src: _Source, sim: dict, after: int) -> tuple[tuple[str, str], ...]:
    table = sim.get("gauge_protocols", {})
    if not isinstance(table, dict):
        raise src.fail("simulator.gauge_protocols must be a table like { z_y = \"usb-itn\" }",
                       "gauge_protocols", after)
    for gauge, protocol in table.items():
        if gauge not in GAUGE_KEYS:
            raise src.fail(f"gauge_protocols: {gauge!r} is not one of {', '.join(GAUGE_KEYS)}",
                           "gauge_protocols", after)
        if protocol not in PROTOCOLS:
            raise src.fail(f"gauge_protocols: {gauge} = {protocol!r} is not one of "
                           f"{', '.join(PROTOCOLS)}", "gauge_protocols", after)
    return tuple(sorted(table.items()))


def _choice(src: _Source, table: dict, key: str, choices: tuple[str, ...], where: str,
            after: int) -> str:
    if key not in table:
        return choices[0]
    value = table[key]
    if value not in choices:
        raise src.fail(f"{where}.{key} must be one of {', '.join(choices)}, got {value!r}",
                       key, after)
    return value


def _protocol(src: _Source, proto: dict, stab: dict, machine: MachineSpec) -> ProtocolConfig:
    after = src.line("protocol") or 0
    kwargs: dict[str, Any] = {}
    for key, kind in (("cycles", int), ("approach", str), ("overshoot_mm", (int, float)),
                      ("settle_s", (int, float)), ("move_timeout_s", (int, float)),
                      ("legs", list), ("postures", list)):
        if key in proto:
            kwargs[key] = _typed(src, proto, key, kind, "protocol", after)
    if "legs" in kwargs:
        kwargs["legs"] = tuple(kwargs["legs"])
    if "postures" in kwargs:
        postures = []
        for p in kwargs["postures"]:
            if isinstance(p, bool) or not isinstance(p, str | int | float):
                raise src.fail(f"postures: {p!r} is not zero, max, min or a number in mm",
                               "postures", after)
            postures.append(p if isinstance(p, str) else float(p))
        kwargs["postures"] = tuple(postures)
    after_stab = src.line("stability") or 0
    rule = {}
    for key, kind in (("readings", int), ("tolerance_mm", (int, float)),
                      ("timeout_s", (int, float))):
        if key in stab:
            rule[key] = _typed(src, stab, key, kind, "stability", after_stab)
    try:
        config = ProtocolConfig(stability=StabilityRule(**rule), **kwargs)
        check_postures(config, machine)
    except ValueError as exc:
        key = next((k for k in ("postures", "approach", "cycles", "legs", "overshoot_mm")
                    if k in str(exc) or k.rstrip("s") in str(exc)), "postures")
        raise src.fail(str(exc), key, after) from None
    return config


def _controller(src: _Source, table: dict, base: Path) -> ControllerSpec:
    after = src.line("controller") or 0
    _check_keys(src, table, _CONTROLLER, "[controller]", after)
    if "profile" not in table:
        raise src.fail("[controller] needs 'profile'", "controller")
    profile = _typed(src, table, "profile", str, "controller", after)
    axes = _controller_axes(src, table.get("axes", {}), after)
    if "port" not in table and not all(a in axes and axes[a].port for a in "xyz"):
        raise src.fail("[controller] needs 'port', or a port for each of x, y and z in "
                       "[controller.axes]", "controller")
    offsets_file = None
    if "offsets_file" in table:
        offsets_file = (base / _typed(src, table, "offsets_file", str, "controller", after)
                        ).resolve()
        kind = _offset_kind(profile)
        if kind not in (None, "software"):
            raise src.fail(f"offsets_file: profile {profile!r} keeps the joint offsets in the "
                           f"controller ({kind}); a software offset table does not apply",
                           "offsets_file", after)
    _check_unit_ids(src, profile, table.get("port", ""), axes, after)
    return ControllerSpec(
        profile=profile,
        port=_typed(src, table, "port", str, "controller", after) if "port" in table else "",
        axes=axes,
        baudrate=_typed(src, table, "baudrate", int, "controller", after)
        if "baudrate" in table else None,
        timeout_s=float(_typed(src, table, "timeout_s", (int, float), "controller", after))
        if "timeout_s" in table else 1.0,
        offsets_file=offsets_file, reconnect=_reconnect_policy(src, table, after))


def _reconnect_policy(src: _Source, table: dict, after: int) -> ReconnectPolicy:
    default = ReconnectPolicy()
    return ReconnectPolicy(
        attempts=_typed(src, table, "reconnect_attempts", int, "controller", after)
        if "reconnect_attempts" in table else default.attempts,
        backoff_s=float(_typed(src, table, "reconnect_backoff_s", (int, float), "controller",
                               after)) if "reconnect_backoff_s" in table else default.backoff_s)


def _controller_axes(src: _Source, table: Any, after: int) -> dict[str, AxisEndpoint]:
    if not isinstance(table, dict):
        raise src.fail("[controller.axes] must be a table of x, y, z", "axes", after)
    out: dict[str, AxisEndpoint] = {}
    for axis, entry in table.items():
        if axis not in ("x", "y", "z"):
            raise src.fail(f"[controller.axes] has no axis {axis!r} (x, y, z)", axis, after)
        if not isinstance(entry, dict):
            raise src.fail(f"controller.axes.{axis} must be a table such as "
                           '{ port = "192.168.3.11:502", device_id = 255 }', axis, after)
        _check_keys(src, entry, _CONTROLLER_AXIS, f"[controller.axes.{axis}]", after)
        device_id = None
        if "device_id" in entry:
            device_id = _typed(src, entry, "device_id", int, f"controller.axes.{axis}", after)
            if not 0 <= device_id <= 255:
                raise src.fail(f"controller.axes.{axis}.device_id must be 0..255, got "
                               f"{device_id}", "device_id", after)
        port = (_typed(src, entry, "port", str, f"controller.axes.{axis}", after)
                if "port" in entry else None)
        out[axis] = AxisEndpoint(port, device_id)
    return out


def _check_unit_ids(src: _Source, profile: str, shared: Any, axes: dict[str, AxisEndpoint],
                    after: int) -> None:
    """A serial (RTU) endpoint addresses units 1..247 only (Modbus over Serial Line
    V1.02 §2.2); TCP takes 0..255."""
    from drivers.axes.profile import load_profile

    try:
        ids = dict(load_profile(profile).device_ids)
    except (InputError, OSError):
        return  # the station reports the profile's own error
    for axis, endpoint in axes.items():
        if endpoint.device_id is not None:
            ids[axis] = endpoint.device_id
    for axis, unit in ids.items():
        endpoint = axes.get(axis)
        port = endpoint.port if endpoint is not None and endpoint.port else shared
        host, sep, number = str(port).rpartition(":")
        serial = not (sep and number.isdigit() and not str(port).startswith("/"))
        if serial and not 1 <= unit <= 247:
            raise src.fail(f"axis {axis}: device id {unit} cannot be addressed over Modbus RTU "
                           f"on {port} (1..247); set controller.axes.{axis}.device_id",
                           "axes" if axes else "profile", after)


def _offset_kind(profile: str) -> str | None:
    """How the profile keeps joint offsets; None when it does not load (the station
    reports that, with the profile's own error)."""
    from drivers.axes.profile import load_profile

    try:
        return load_profile(profile).offset.kind
    except (InputError, OSError):
        return None


def _gauges(src: _Source, tables: list, protocol: ProtocolConfig) -> list[GaugeSpec]:
    lines = _table_lines(src, "gauges")
    out: list[GaugeSpec] = []
    on_channel: dict[tuple[str, str | None], list[tuple[str, int]]] = {}
    seen_gauge: dict[str, int] = {}
    for k, table in enumerate(tables):
        start = lines[k] if k < len(lines) else 0
        after = start - 1 if start else 0
        _check_keys(src, table, _GAUGE, "[[gauges]]", after)
        for key in ("gauge", "protocol", "port"):
            if key not in table:
                raise InputError(src.path, f"[[gauges]] entry needs {key!r}", start or None)
        gauge = _typed(src, table, "gauge", str, "gauges", after)
        if gauge not in GAUGE_KEYS:
            raise src.fail(f"gauge {gauge!r} is not one of {', '.join(GAUGE_KEYS)} "
                           "(AXIS_LEG: along AXIS on that leg)", "gauge", after)
        protocol_name = _typed(src, table, "protocol", str, "gauges", after)
        if protocol_name not in PROTOCOLS:
            raise src.fail(f"protocol {protocol_name!r} is not one of {', '.join(PROTOCOLS)}",
                           "protocol", after)
        unit = str(table.get("unit", "mm"))
        if unit not in ("mm", "inch"):
            raise src.fail(f"unit {unit!r} must be mm or inch (as set on the gauge)", "unit",
                           after)
        port = _typed(src, table, "port", str, "gauges", after)
        channel = str(table["channel"]) if "channel" in table else None
        if gauge in seen_gauge:
            raise InputError(src.path, f"gauge {gauge} appears twice (first on line "
                             f"{seen_gauge[gauge]})", start or None)
        leg = Gauge.parse(gauge).leg
        same_leg = [(g, n) for g, n in on_channel.get((port, channel), [])
                    if Gauge.parse(g).leg == leg]
        if same_leg:
            where = f"port {port}" + (f" channel {channel}" if channel else "")
            other, line = same_leg[0]
            raise InputError(src.path, f"gauges {other} (line {line}) and {gauge} of the {leg} "
                             f"leg both on {where}: the two gauges of a leg each need their "
                             "own port or channel (one indicator may serve one gauge per leg, "
                             "moved from leg to leg)", start or None)
        first_on_port = next((g for g in out if g.port == port), None)
        if first_on_port is not None and first_on_port.protocol != protocol_name:
            raise InputError(src.path, f"gauge {gauge} on port {port} is {protocol_name} but "
                             f"{first_on_port.gauge} on the same port is "
                             f"{first_on_port.protocol}: one port speaks one protocol",
                             start or None)
        seen_gauge[gauge] = start
        on_channel.setdefault((port, channel), []).append((gauge, start))
        out.append(GaugeSpec(gauge, protocol_name, port, channel, unit,
                             str(table.get("serial", "")),
                             int(table["baudrate"]) if "baudrate" in table else None))
    return out
