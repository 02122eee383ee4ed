"""Step 1: connect the instruments: the ports listed (a typed port or URL always
accepted: pseudo-terminals and ``socket://`` are never listed), the controller
checked, each gauge test-read; each check retried, changed, or skipped with a reason."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

from ogacq_drivers.axes.profile import ProfileError, available_profiles, load_profile
from ogacq_drivers.errors import DriverError
from ogacq_drivers.indicators import BACKENDS
from ogacq_drivers.indicators.backend import load
from ogacq.campaign.campaign_file import ControllerSpec, GaugeSpec
from ogacq.campaign.station import (  # as the campaign connects
    is_modbus_tcp,
    open_controller,
    open_gauges,
)
from ogacq.cli.plain import shown, table_of
from ogacq.cli.wizard.ui import Option, Screen, detail
from ogacq.model.gauges import MOVED_INDICATORS, Gauge, gauges_on
from ogacq.model.parameters import AXES

BY_EYE = "by eye"


@dataclass(frozen=True)
class DetectedPort:
    device: str
    description: str
    suggested_for: str = ""  # "controller", a gauge key or "indicator N" (the simulator knows)
    protocol: str = ""


@dataclass
class StationChoice:
    """What the technician connected: the campaign's station, and what was skipped."""

    controller: ControllerSpec
    gauges: dict[str, GaugeSpec] = field(default_factory=dict)  # read over a serial link
    by_eye: set[str] = field(default_factory=set)  # dial indicators, values typed in
    notes: list[dict[str, str]] = field(default_factory=list)  # skips, with their reasons


def gauges_of(legs: Sequence[str]) -> list[str]:
    return [g.key for g in gauges_on(tuple(legs))]


def describe_gauge(gauge: str) -> str:
    g = Gauge.parse(gauge)
    return f"{gauge} (on the {g.leg} leg, along {g.axis})"


def detect_ports(simulated: dict[str, Any] | None = None) -> list[DetectedPort]:
    """Serial ports the system lists, and the simulator's endpoints when rehearsing."""
    found: list[DetectedPort] = []
    if simulated is not None:
        m = simulated["modbus"]
        where = f"{m['host']}:{m['port']}" if m["transport"] == "tcp" else m["port"]
        found.append(DetectedPort(where, f"simulated axis controller ({m['profile']}, "
                                         f"Modbus {m['transport'].upper()})",
                                  "controller", m["profile"]))
        served: dict[tuple[str, str | None], list[str]] = {}
        for key, g in simulated["gauges"].items():
            served.setdefault((g["port"], g.get("channel")), []).append(key)
        for number, ((port, _), keys) in enumerate(served.items(), 1):
            protocol = simulated["gauges"][keys[0]]["protocol"]
            if len(keys) == 1:
                found.append(DetectedPort(port, f"simulated gauge {keys[0]} ({protocol})",
                                          keys[0], protocol))
            else:
                found.append(DetectedPort(port, f"simulated indicator {number}, moved from leg "
                                                f"to leg: {', '.join(keys)} ({protocol})",
                                          f"indicator {number}", protocol))
    try:
        from serial.tools.list_ports import comports

        listed = sorted(comports(), key=lambda p: p.device)
    except Exception:  # listing is a convenience; a typed port always works
        listed = []
    for info in listed:
        details = [d for d in (info.description, info.manufacturer, info.serial_number)
                   if d and d != "n/a"]
        hwid = info.hwid if info.hwid and info.hwid != "n/a" else ""
        found.append(DetectedPort(info.device, ", ".join(details) or hwid or "no description"))
    return found + _protocol_devices()


def _protocol_devices() -> list[DetectedPort]:
    """The devices the serial port list does not show (USB cables, input devices), as
    each protocol's backend finds them. A listing is a convenience, so a protocol whose
    search fails (no pyusb, no libusb, no permission) just lists nothing: its port can
    be typed."""
    found: list[DetectedPort] = []
    for name, entry in BACKENDS.items():
        if not entry.hints.find:
            continue
        try:
            devices = load(entry.hints.find)()
        except Exception:
            continue
        found += [DetectedPort(d.port, f"{d.description} (protocol {name})") for d in devices]
    return found


def show_ports(screen: Screen, ports: Sequence[DetectedPort]) -> None:
    if not ports:
        screen.say("No serial port is listed. Type the port of each device "
                   "(/dev/ttyUSB0, COM3, socket://host:port, or host:port for Modbus TCP).")
        return
    table = table_of(">#", "port", "description", title="Ports found", title_justify="left")
    for number, port in enumerate(ports, 1):
        table.add_row(str(number), shown(port.device), shown(port.description))
    screen.say(table)
    screen.note("Pseudo-terminals and network ports are not listed by the system: "
                "type them in full.")


def _port_answer(answer: str, ports: Sequence[DetectedPort]) -> str:
    if answer.isdigit():
        number = int(answer)
        if not 1 <= number <= len(ports):
            raise ValueError(f"there is no port number {number} in the list")
        return ports[number - 1].device
    if not answer:
        raise ValueError("type a number from the list, or a port")
    return answer


# ------------------------------------------------------------------------ controller

def controller_ports(spec: ControllerSpec) -> list[str]:
    """Every port the controller answers on (the shared one, each axis's own)."""
    return sorted({spec.port_of(axis) for axis in AXES} | ({spec.port} if spec.port else set()))


def check_controller(spec: ControllerSpec) -> str:
    """One line on the axes' state; DriverError or ProfileError when it does not answer."""
    with open_controller(spec) as controller:
        status = controller.read_status()
    axes = ", ".join(f"{a} at {s.position_mm:+.3f} mm" for a, s in status.items())
    servo = "servo on" if all(s.servo_on for s in status.values()) else "servo off"
    alarms = [f"{a}: alarm {s.alarm_code}" for a, s in status.items() if s.alarm_code or s.fault]
    return f"{axes}; {servo}; " + ("; ".join(alarms) if alarms else "no alarm")


def choose_controller(screen: Screen, ports: Sequence[DetectedPort],
                      notes: list[dict[str, str]]) -> ControllerSpec:
    suggested = next((p for p in ports if p.suggested_for == "controller"), None)
    profiles = available_profiles()
    default_profile = suggested.protocol if suggested else profiles[0]
    screen.say("[bold]Axis controller[/]")
    while True:
        options = [Option(str(k), name) for k, name in enumerate(profiles, 1)]
        profile_key = screen.choose("Register map of the controller", options,
                                    default=str(profiles.index(default_profile) + 1))
        profile = profiles[int(profile_key) - 1]
        port = screen.ask_parsed(
            "Controller port: a number from the list, a serial device, or host:port",
            lambda a: _port_answer(a, ports),
            default=suggested.device if suggested else None)
        spec = ControllerSpec(profile, port, _ask_baudrate(screen, profile, port))
        while True:
            screen.say(f"Checking the controller on {shown(port)} …")
            try:
                screen.ok(f"controller answers: {check_controller(spec)}")
                return spec
            except (DriverError, ProfileError, OSError) as exc:
                screen.problem(f"the controller on {port} does not answer: {exc}")
                screen.say("Check that it is powered, the cable or network, and the port.")
            choice = screen.choose("What now?", [
                Option("r", "retry"),
                Option("c", "change the port or the register map"),
                Option("s", "skip this check (give a reason)"),
            ], default="r")
            if choice == "s":
                notes.append({"step": "controller check", "port": port,
                              "reason": screen.reason("skip the controller check")})
                return spec
            if choice == "c":
                break


def _ask_baudrate(screen: Screen, profile: str, port: str) -> int | None:
    """The bit rate of a serial (Modbus RTU) controller, the profile's as the default;
    None over TCP, which has none."""
    if is_modbus_tcp(port):
        return None
    try:
        default = load_profile(profile).transport.baudrate
    except ProfileError:
        default = 38400
    return screen.ask_parsed("Baud rate of the controller's serial line (bit/s; the drive's "
                             "own setting)", _baudrate, default=str(default))


def _baudrate(answer: str) -> int:
    if not answer.isdigit() or int(answer) <= 0:
        raise ValueError(f"{answer!r} is not a baud rate: a whole number such as 38400")
    return int(answer)


# ------------------------------------------------------------------------ gauges

def test_read(spec: GaugeSpec, timeout_s: float = 1.0) -> float:
    """One value from the gauge, opened as the campaign will open it (its line settings)."""
    with open_gauges([spec]) as gauges:
        return gauges[spec.gauge].read(timeout_s=timeout_s).value_mm


def choose_gauges(screen: Screen, ports: Sequence[DetectedPort], legs: Sequence[str],
                  notes: list[dict[str, str]], all_by_eye: bool = False,
                  indicators: int | None = None, rehearsal_indicators: int | None = None,
                  controller_ports: Sequence[str] = (),
                  ) -> tuple[dict[str, GaugeSpec], set[str]]:
    """The gauges' specs (by key) and the gauges read by eye. ``indicators``: 6 or 2
    if already known (else asked); ``rehearsal_indicators``: what the simulator has;
    ``controller_ports``: where the controller is, refused for a gauge (one port,
    one device)."""
    keys = gauges_of(legs)
    screen.say()
    screen.say("[bold]Gauges[/]")
    protocols = list(BACKENDS)
    suggested = {p.suggested_for: p for p in ports if p.suggested_for in keys}
    default_protocol = next(iter(suggested.values())).protocol if suggested else protocols[0]
    options = [Option(str(k), f"{name}: {BACKENDS[name].description}")
               for k, name in enumerate(protocols, 1)]
    options.append(Option(str(len(protocols) + 1),
                          "dial indicators read by eye: you type each reading"))
    default = str(len(protocols) + 1) if all_by_eye else \
        str(protocols.index(default_protocol) + 1)
    answer = int(screen.choose("How are the gauges read?", options, default=default))
    if answer == len(protocols) + 1:
        screen.say("The wizard will ask for every reading, check it against what is "
                   "expected, and tell you when to read.")
        return {}, set(keys)
    protocol = protocols[answer - 1]
    show_hints(screen, protocol)

    controller = {port: "the controller's" for port in controller_ports if port}
    if _indicator_count(screen, indicators, rehearsal_indicators) == 2:
        screen.say("Type each indicator's port (a number from the list, a device or a URL), "
                   "or [bold]m[/] to read it by eye.")
        return _ports_of(screen, ports, _moved_indicators(legs), protocol, notes, controller)
    screen.say("Type each gauge's port (a number from the list, a device or a URL), or "
               "[bold]m[/] to read that gauge by eye.")
    return _ports_of(screen, ports, [_Served((g,), g, f"gauge {g}", f"Gauge {describe_gauge(g)}")
                                     for g in keys], protocol, notes, controller)


def show_hints(screen: Screen, protocol: str) -> None:
    """What the protocol's backend says about connecting such a gauge."""
    from rich.markup import escape  # the table's words, not markup (a plugin's too)

    entry = BACKENDS[protocol]
    if entry.hints.note:
        screen.note(escape(entry.hints.note))
    line = f"; the line: {entry.line}" if entry.line else ""
    channel = f"; a channel is {entry.hints.channel}" if entry.hints.channel else ""
    screen.note(escape(f"The port of a {protocol} gauge: {entry.hints.ports}{line}{channel}."))


def _indicator_count(screen: Screen, known: int | None, rehearsal: int | None) -> int:
    options = [Option("6", "six, two per leg, left in place for the whole campaign"),
               Option("2", "two, moved from leg to leg (as in the papers): you set them on "
                           "each leg when the machine stops there")]
    if known is not None:  # --indicators: a rehearsal's simulator was built with it
        return known
    while True:
        count = int(screen.choose("How many indicators?", options,
                                  default=str(rehearsal or 6)))
        if rehearsal is None or count == rehearsal:
            return count
        screen.problem(f"this rehearsal's simulator has {rehearsal} indicators; to rehearse "
                       f"with {count}, start again with --indicators {count}")


@dataclass(frozen=True)
class _Served:
    """What one port serves: a gauge, or an indicator moved from leg to leg."""

    gauges: tuple[str, ...]
    suggested_for: str  # as DetectedPort.suggested_for names it
    name: str  # "gauge x_y", "indicator 1"
    label: str  # the port question


def _moved_indicators(legs: Sequence[str]) -> list[_Served]:
    """Two indicators, each serving one gauge on every leg (same port, its own zero
    on each leg): one port question and one test read per indicator."""
    served = []
    for number, keys in enumerate(MOVED_INDICATORS, 1):
        gauges = tuple(g for g in keys if Gauge.parse(g).leg in legs)
        label = f"Indicator {number} (" + ", ".join(
            f"along {Gauge.parse(g).axis} on the {Gauge.parse(g).leg} leg" for g in gauges) + ")"
        served.append(_Served(gauges, f"indicator {number}", f"indicator {number}", label))
    return served


def _ports_of(screen: Screen, ports: Sequence[DetectedPort], served: Sequence[_Served],
              protocol: str, notes: list[dict[str, str]], taken: dict[str, str],
              ) -> tuple[dict[str, GaugeSpec], set[str]]:
    """Each one's port, asked and test-read (``taken``: ports already in use, by whom);
    the gauges' specs and those read by eye."""
    chosen: dict[str, GaugeSpec] = {}
    by_eye: set[str] = set()
    free = [p for p in ports if not p.suggested_for]
    for one in served:
        guess = next((p for p in ports if p.suggested_for == one.suggested_for), None) \
            or next((p for p in free if p.device not in taken), None)
        spec = _one_gauge(screen, one, protocol, ports, taken, guess.device if guess else None,
                          notes)
        if spec is None:
            by_eye.update(one.gauges)
        else:
            chosen.update({g: replace(spec, gauge=g) for g in one.gauges})
            taken = taken | {spec.port: f"{one.name}'s"}
    return chosen, by_eye


def _one_gauge(screen: Screen, one: _Served, protocol: str, ports: Sequence[DetectedPort],
               taken: dict[str, str], default: str | None, notes: list[dict[str, str]],
               ) -> GaugeSpec | None:
    """The spec of the gauge (the first) ``one`` serves once it read (or its test was
    skipped); None: read by eye."""
    gauge, name = one.gauges[0], one.name
    while True:
        def parse(answer: str) -> str:
            if answer.lower() == "m":
                return BY_EYE
            port = _port_answer(answer, ports)
            if port in taken:  # one port, one device: a gauge never shares the controller's
                raise ValueError(f"{port} is {taken[port]} port already: one port, one device "
                                 "(each gauge its own port or channel)")
            return port

        port = screen.ask_parsed(one.label, parse, default=default)
        if port == BY_EYE:
            return None
        spec = GaugeSpec(gauge, protocol, port)
        while True:
            try:
                value = test_read(spec)
                screen.ok(f"{name} reads {value:.4f} mm on {port}")
                return spec
            except DriverError as exc:
                screen.problem(f"{name} on {port} did not give a value: {detail(exc)}")
                screen.say("Check the cable, that the gauge is on, and its interface setting.")
            choice = screen.choose("What now?", [
                Option("r", "retry"),
                Option("c", "change the port"),
                Option("m", f"read {name} by eye instead (type its values)"),
                Option("s", "skip this test (give a reason)"),
            ], default="r")
            if choice in ("m", "s"):  # by eye, or this link as it is, for a reason
                why = f"read {name} by eye" if choice == "m" else f"skip the test of {name}"
                notes.append({"step": "gauge test", "gauge": gauge, "port": port,
                              "reason": screen.reason(why)})
                return None if choice == "m" else spec
            if choice == "c":  # the suggested port stays the default
                break


def connect_instruments(screen: Screen, ports: Sequence[DetectedPort], legs: Sequence[str] = AXES,
                        all_by_eye: bool = False, indicators: int | None = None,
                        rehearsal_indicators: int | None = None) -> StationChoice:
    show_ports(screen, ports)
    notes: list[dict[str, str]] = []
    controller = choose_controller(screen, ports, notes)
    gauges, by_eye = choose_gauges(screen, ports, legs, notes, all_by_eye, indicators,
                                   rehearsal_indicators, controller_ports(controller))
    return StationChoice(controller, gauges, by_eye, notes)
