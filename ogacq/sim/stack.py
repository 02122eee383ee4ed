"""Everything the simulator serves, started together over one simulated machine:
the Modbus controller (TCP on loopback, or RTU on a pseudo-terminal) and one
gauge per leg and direction: serial gauges on pseudo-terminals, loopback sockets
or RFC 2217 (the Sylvac simplex cable), USB-ITN cables over the software USB
backend (``usbsim://``) or as a keyboard (an input-event device node).

Clients connect with the real drivers; only this module knows the endpoints
are simulated.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from ogacq_drivers.axes.profile import load_profile
from ogacq_drivers.sim.clock import SimClock
from ogacq_drivers.sim.gauges import (
    GaugeEndpoint,
    SimSetup,
    SimulatedGauge,
    simulated_gauge,
    transport_of,
)
from ogacq_drivers.sim.modbus_server import ModbusSimServer
from ogacq_drivers.sim.motion import MotionModel
from ogacq.model.gauges import GAUGE_KEYS, MOVED_INDICATORS, Gauge
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import AXES
from ogacq.sim.machine import SimMachine
from ogacq.sim.truth import SimTruth

# A linear scale's scatter read on its counter at rest: 0.3 µm (no source: an order of
# magnitude; a third of its 1 µm display step, which it dithers so that a mean of its
# values is biased by the rounding at most 0.05 µm).
SCALE_NOISE_MM = 0.0003


@dataclass
class SimulatorConfig:
    machine: MachineSpec
    truth: SimTruth
    profile: str = "cia402"
    speed: float = 20.0
    seed: int = 0
    gauge_protocol: str = "mitutoyo-01a"
    # protocol per gauge key, overriding gauge_protocol (a mixed station)
    gauge_protocols: dict[str, str] = field(default_factory=dict)
    # "separate": one port per gauge; "multiplexer": all six on one 01A
    # multiplexer port, channels 1..6 (a DMX/MUX box); "moved": two indicators,
    # moved from leg to leg as the papers did (see SimulatorStack.set_gauges)
    gauge_layout: str = "separate"
    # The Modbus TCP port (0: any free one); drives served one per endpoint take it
    # and the ports that follow, one per axis.
    modbus_port: int = 0
    # the shop's temperature, degC: what the controller's temperature registers show
    # (the truth's legs are already expanded to it, see SimTruth.at_temperature)
    ambient_c: float = 20.0
    # how many times faster than their baud rates the gauges' serial lines run (a
    # rehearsal not about the line's timing asks for `speed`; 1: the real lines)
    line_speed: float = 1.0
    # the axes with a scale along the actuator (ISO 230-2's positioning test), served
    # as gauges of gauge_protocol, and their display step (their noise: SCALE_NOISE_MM)
    axis_scales: tuple[str, ...] = ()
    scale_resolution_mm: float = 0.001


# Gauges that push their values (U-WAVE's DATA button, the keyboard cable's switch):
# the simulated operator presses it this often, so a campaign gets readings.
PUSH_PERIOD_S = 0.05


def make_gauge(protocol: str, source: Callable[[], float], *, resolution_mm: float,
               name: str, transport: str = "pty", line_speed: float = 1.0) -> SimulatedGauge:
    """The simulated endpoint serving one gauge of ``protocol`` (any of ``BACKENDS``:
    its backend names the simulated instrument), not yet started."""
    return simulated_gauge(protocol, source, SimSetup(
        resolution_mm=resolution_mm, transport=transport_of(transport), name=name,
        push_period_s=PUSH_PERIOD_S, line_speed=line_speed))


class SimulatorStack:
    def __init__(self, config: SimulatorConfig) -> None:
        self.config = config
        self.clock = SimClock(config.speed)
        m = config.machine
        self.motion = MotionModel(self.clock, soft_min_mm=m.rho_min_mm, soft_max_mm=m.rho_max_mm)
        # the ringing as stated at any speed: a gauge shows its mean between two
        # values (SimMachine.vibration_mm), which does not alias however slowly a
        # rehearsal at speed reads it
        self.machine = SimMachine(m, config.truth, self.motion,
                                  self.clock, seed=config.seed)
        profile = load_profile(config.profile)
        if not profile.endpoint_per_axis:
            self.servers = [ModbusSimServer(profile, self.motion, port=config.modbus_port,
                                            temperatures_c=self.temperatures_c)]
        else:  # one drive per address (MR-JE-C: unit 255 each): one endpoint per axis
            self.servers = [ModbusSimServer(profile, self.motion, axes=[a],
                                            port=config.modbus_port + k if config.modbus_port
                                            else 0, temperatures_c=self.temperatures_c)
                            for k, a in enumerate(profile.device_ids)]
        self.server = self.servers[0]
        self.gauges: dict[str, SimulatedGauge] = {}
        self.channels: dict[str, str | None] = {}
        sources = {key: self.machine.value_source(*Gauge.parse(key).indices)
                   for key in GAUGE_KEYS}
        if config.gauge_layout == "multiplexer":  # an 01A multiplexer box (DMX-1, MUX-10)
            channels = {key: str(n) for n, key in enumerate(GAUGE_KEYS, 1)}
            mux = GaugeEndpoint("mitutoyo-01a", {channels[k]: sources[k] for k in GAUGE_KEYS},
                                resolution_mm=m.gauge_resolution_mm,
                                name="sim multiplexer", line_speed=config.line_speed)
            self.gauges = dict.fromkeys(GAUGE_KEYS, mux)
            self.channels = dict(channels)
        elif config.gauge_layout == "separate":
            for key in GAUGE_KEYS:
                self.gauges[key] = make_gauge(
                    config.gauge_protocols.get(key, config.gauge_protocol), sources[key],
                    resolution_mm=m.gauge_resolution_mm,
                    name=f"sim gauge {key}", line_speed=config.line_speed)
                self.channels[key] = None
        elif config.gauge_layout == "moved":
            self._mounted_leg = AXES[0]
            for number, keys in enumerate(MOVED_INDICATORS, 1):
                indicator = make_gauge(
                    config.gauge_protocol, self._mounted_source(keys, sources),
                    resolution_mm=m.gauge_resolution_mm,
                    name=f"sim indicator {number}", line_speed=config.line_speed)
                self.gauges.update(dict.fromkeys(keys, indicator))
                self.channels.update(dict.fromkeys(keys))
        else:
            raise ValueError(f"gauge_layout must be 'separate', 'multiplexer' or 'moved', "
                             f"got {config.gauge_layout!r}")
        # each axis scale on its own line, reading the same simulated machine
        self.scales: dict[str, SimulatedGauge] = {
            axis: make_gauge(config.gauge_protocol,
                             self.machine.scale_source(AXES.index(axis), SCALE_NOISE_MM),
                             resolution_mm=config.scale_resolution_mm,
                             name=f"sim {axis} axis scale", line_speed=config.line_speed)
            for axis in config.axis_scales}
        self._started = False

    def start(self) -> SimulatorStack:
        try:
            for server in self.servers:
                server.start()
            for endpoint in self._endpoints():
                endpoint.start()
        except BaseException:
            self.close()
            raise
        self._started = True
        return self

    def close(self) -> None:
        for endpoint in self._endpoints():
            endpoint.close()
        for server in self.servers:
            server.stop()
        self._started = False

    def __enter__(self) -> SimulatorStack:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def ambient_c(self) -> float:
        return self.config.ambient_c

    def temperatures_c(self) -> dict[str, float]:
        """What a thermometer in the simulated shop and one on the machine read: the
        machine has settled to the ambient."""
        return {"ambient": self.config.ambient_c, "machine": self.config.ambient_c}

    @property
    def moves_indicators(self) -> bool:
        return self.config.gauge_layout == "moved"

    def set_gauges(self, leg: str) -> None:
        """The simulated operator moves the two indicators to ``leg`` and sets them
        (each gauge's reading at the Zero posture is its own, as set on a stand)."""
        if not self.moves_indicators:
            raise ValueError("the simulated gauges stay in place (gauge_layout "
                             f"{self.config.gauge_layout!r}); only 'moved' indicators move")
        if leg not in AXES:
            raise ValueError(f"no leg {leg!r}; legs are {', '.join(AXES)}")
        self._mounted_leg = leg

    def _mounted_source(self, keys: tuple[str, ...],
                        sources: dict[str, Callable[[], float]]) -> Callable[[], float]:
        by_leg = {Gauge.parse(key).leg: sources[key] for key in keys}
        return lambda: by_leg[self._mounted_leg]()

    def _endpoints(self) -> list[Any]:
        return list({id(g): g for g in [*self.gauges.values(), *self.scales.values()]
                     }.values())

    def info(self) -> dict[str, Any]:
        """Where to connect, as ``ogacq sim --json`` prints it."""
        per_axis = ({s.axes[0]: s.address.as_dict() for s in self.servers}
                    if len(self.servers) > 1 else {})
        return {
            "modbus": self.server.address.as_dict(),
            **({"modbus_axes": per_axis} if per_axis else {}),
            "gauges": {key: {"port": g.port, "protocol": g.protocol}
                       | ({"channel": self.channels[key]} if self.channels[key] else {})
                       for key, g in self.gauges.items()},
            **({"axis_scales": {axis: {"port": g.port, "protocol": g.protocol}
                                for axis, g in self.scales.items()}} if self.scales else {}),
        }
