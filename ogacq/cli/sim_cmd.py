"""``ogacq sim``: the simulated machine's controller and gauges, until interrupted."""

from __future__ import annotations

import contextlib
import json
import secrets
import signal
import threading
from dataclasses import replace
from pathlib import Path
from typing import Annotated

import typer

from ogacq_drivers.axes.profile import load_profile
from ogacq_drivers.indicators import BACKENDS, DEFAULT_PROTOCOL
from ogacq.campaign.campaign_file import Campaign, SimulatorSpec, campaign_text
from ogacq.campaign.station import simulator_endpoints, simulator_scales, start_simulator
from ogacq.cli.options import (
    DEFAULT_SEED,
    DEFAULT_SPEED,
    GaugeProtocol,
    JsonOption,
    ProfileChoice,
    axis_scales_option,
    per_axis_profiles,
    profile_help,
    scale_axes,
    seed_option,
)
from ogacq.cli.outputs import ForceOption, check_output_file
from ogacq.cli.render import print_sim
from ogacq.errors import InputError
from ogacq.io.atomic import write_atomically
from ogacq.io.machine_file import read_machine, write_machine
from ogacq.model.gauges import GAUGE_KEYS
from ogacq.model.machine import PAPER_PROTOTYPE, MachineSpec
from ogacq.protocol.plan import ProtocolConfig
from ogacq.sim.stack import SimulatorStack


def sim(
    profile: Annotated[ProfileChoice, typer.Option(
        help=profile_help("Controller register map (Modbus TCP on loopback, Modbus RTU on a "
                          "pseudo-terminal)"))] = ProfileChoice["cia402"],
    effects: Annotated[Path | None, typer.Option(
        help="TOML file of hidden effects (joint_offset, squareness, ... gauges.noise_mm).")]
    = None,
    seed: Annotated[int, seed_option("Seed of the hidden offsets and the noise (the same "
                                     "default in demo, sim and wizard).")] = DEFAULT_SEED,
    machine: Annotated[Path | None, typer.Option(
        "--machine", "-m", help="Machine file (default: the papers' prototype).")] = None,
    speed: Annotated[float, typer.Option(
        min=0.01, help="Simulated time runs this many times faster than real time.")
    ] = DEFAULT_SPEED,
    gauge_protocol: Annotated[GaugeProtocol, typer.Option(
        help="What the simulated gauges speak.")] = GaugeProtocol[DEFAULT_PROTOCOL],
    gauge: Annotated[list[str] | None, typer.Option(
        help="GAUGE=PROTOCOL for one gauge (repeatable), e.g. z_y=usb-itn: a mixed "
             "station.")] = None,
    port: Annotated[int | None, typer.Option(
        min=1, max=65535, help="Modbus TCP port of the controller (default: a free one; "
                               f"with {per_axis_profiles()}, axis y and z take the next "
                               "two).")] = None,
    write_campaign: Annotated[Path | None, typer.Option(
        help="Write a campaign file that runs against this simulator (`ogacq run FILE` "
             "while it serves); without --machine, the machine file goes beside it as "
             "machine.toml.")] = None,
    axis_scales: Annotated[str, axis_scales_option(
        "The axes (e.g. x,y,z) along which a scale is served, each on its own line "
        "(ISO 230-2's positioning test: `ogacq positioning`, `ogacq calibrate`); "
        "--write-campaign declares them.")] = "",
    force: ForceOption = False,
    as_json: JsonOption = False,
) -> None:
    """Serve a simulated machine on loopback and pseudo-terminals until Ctrl-C."""
    if port and load_profile(profile.value).transport.default != "tcp":
        raise typer.BadParameter(f"profile {profile.value} is served over Modbus RTU on a "
                                 "pseudo-terminal, which has no port number",
                                 param_hint="--port")
    spec = read_machine(machine) if machine else PAPER_PROTOTYPE
    machine_out = None
    if write_campaign is not None:
        check_output_file(write_campaign, "--write-campaign", force=force)
        if machine is None:
            machine_out = write_campaign.parent / "machine.toml"
            if machine_out.exists() and not force:
                # the file `ogacq init machine` writes: say why sim would write it at all
                raise InputError(machine_out, "exists, and --write-campaign writes the "
                                 "simulated machine's file beside the campaign file: give "
                                 f"--machine {machine_out} to simulate that machine, another "
                                 "folder, or --force to replace it")
            check_output_file(machine_out, "--write-campaign folder", force=force)
    simulated = SimulatorSpec(seed=seed, effects=effects, speed=speed, profile=profile.value,
                              gauge_protocol=gauge_protocol.value,
                              gauge_protocols=tuple(sorted(_per_gauge(gauge or []).items())),
                              axis_scales=scale_axes(axis_scales))
    done = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: done.set())
    with contextlib.closing(start_simulator(spec, simulated, modbus_port=port or 0)) as stack:
        if write_campaign is not None:
            if machine is None:
                assert machine_out is not None  # set above, beside the campaign file
                # ogacq's own file: a serial of its own, so that the history tells this
                # simulated machine from the demo's and from a real one of the same name
                spec = replace(spec, serial=f"SIM-{secrets.token_hex(4).upper()}")
                machine = write_machine(machine_out, spec,
                                        "written by `ogacq sim --write-campaign`")
                typer.echo(f"ogacq sim: {machine_out} names the simulated machine "
                           f"{spec.name!r} serial {spec.serial} (its identity in the "
                           "history)", err=True)
            _write_campaign(write_campaign, stack, spec, machine, speed)
        info = stack.info()
        if as_json:
            typer.echo(json.dumps(info))
        else:
            print_sim(info, write_campaign)
        with contextlib.suppress(KeyboardInterrupt):
            while not done.wait(0.5):
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


def _write_campaign(path: Path, stack: SimulatorStack, machine: MachineSpec,
                    machine_path: Path, speed: float) -> None:
    """A campaign file whose station is ``stack``'s endpoints: valid while it serves
    (the gauges' pseudo-terminals are new at each start)."""
    controller, gauges = simulator_endpoints(stack)
    # The simulator's time runs `speed` times faster: the settling it needs, in wall time.
    protocol = ProtocolConfig(settle_s=ProtocolConfig.settle_s / speed)
    campaign = Campaign(path, machine, machine_path,
                        path.parent / "sessions" / f"{path.stem}.jsonl", protocol,
                        controller=controller, gauges=gauges,
                        axis_scales=simulator_scales(stack))
    write_atomically(path, campaign_text(  # whole or not at all: a full disk leaves no half
        campaign, comment="written by `ogacq sim --write-campaign`: talks to that simulator "
                          "while it runs").encode("utf-8"))
