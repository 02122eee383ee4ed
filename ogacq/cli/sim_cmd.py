"""``ogacq sim``: the simulated machine's controller and gauges, until interrupted."""

from __future__ import annotations

import contextlib
import json
import signal
import threading
from pathlib import Path
from typing import Annotated

import typer

from drivers.indicators import BACKENDS, DEFAULT_PROTOCOL
from ogacq.campaign_file import SimulatorSpec
from ogacq.cli.options import DEFAULT_SEED, GaugeProtocol, JsonOption, ProfileChoice, seed_option
from ogacq.cli.render import print_sim
from ogacq.io.machine_file import read_machine
from ogacq.model.gauges import GAUGE_KEYS
from ogacq.model.machine import PAPER_PROTOTYPE
from ogacq.station import start_simulator


def sim(
    profile: Annotated[ProfileChoice, typer.Option(
        help="Controller register map: cia402 (Modbus TCP), iai-pcon (Modbus RTU on a "
             "pseudo-terminal), mr-je-c (one Modbus TCP endpoint per axis, unit 255, "
             "FC 03/08/16) or kinco-fd (RTU).")] = ProfileChoice["cia402"],
    effects: Annotated[Path | None, typer.Option(
        help="TOML file of hidden effects (joint_offset, squareness, ... gauges.noise_mm).")]
    = None,
    seed: Annotated[int, seed_option("Seed of the hidden offsets and the noise (the same "
                                     "default in demo, sim and wizard).")] = DEFAULT_SEED,
    machine: Annotated[Path | None, typer.Option(
        "--machine", "-m", help="Machine file (default: the papers' prototype).")] = None,
    speed: Annotated[float, typer.Option(
        min=0.01, help="Simulated time runs this many times faster than real time.")] = 1.0,
    gauge_protocol: Annotated[GaugeProtocol, typer.Option(
        help="What the simulated gauges speak.")] = GaugeProtocol[DEFAULT_PROTOCOL],
    gauge: Annotated[list[str] | None, typer.Option(
        help="GAUGE=PROTOCOL for one gauge (repeatable), e.g. z_y=usb-itn: a mixed "
             "station.")] = None,
    as_json: JsonOption = False,
) -> None:
    """Serve a simulated machine on loopback and pseudo-terminals until Ctrl-C."""
    spec = read_machine(machine) if machine else PAPER_PROTOTYPE
    simulated = SimulatorSpec(seed=seed, effects=effects, speed=speed, profile=profile.value,
                              gauge_protocol=gauge_protocol.value,
                              gauge_protocols=tuple(sorted(_per_gauge(gauge or []).items())))
    done = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: done.set())
    with contextlib.closing(start_simulator(spec, simulated)) as stack:
        info = stack.info()
        if as_json:
            typer.echo(json.dumps(info))
        else:
            print_sim(info)
        try:
            while not done.wait(0.5):
                pass
        except KeyboardInterrupt:
            pass


def _per_gauge(items: list[str]) -> dict[str, str]:
    out: dict[str, str] = {}
    for item in items:
        key, _, protocol = item.partition("=")
        if key not in GAUGE_KEYS or protocol not in BACKENDS:
            raise typer.BadParameter(
                f"{item!r}: GAUGE=PROTOCOL, GAUGE one of {', '.join(GAUGE_KEYS)}, PROTOCOL one "
                f"of {', '.join(BACKENDS)}", param_hint="--gauge")
        out[key] = protocol
    return out
