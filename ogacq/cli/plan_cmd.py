"""``ogacq plan``: predicted accuracy of a campaign before it is run."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from ogacq.cli.options import JsonOption, MachineOption, ParamSet, seed_option
from ogacq.cli.render import print_plan
from ogacq.errors import InputError
from ogacq.identify.accuracy import planned_observations, predict_accuracy
from ogacq.io.machine_file import read_machine
from ogacq.model.parameters import PARAM_INDEX, PARAM_SETS


def parse_postures(text: str, rho_min: float, rho_max: float) -> list[str | float]:
    out: list[str | float] = []
    for item in (t.strip().lower() for t in text.split(",")):
        if item in ("zero", "max", "min"):
            out.append(item)
            continue
        try:
            value = float(item)
        except ValueError:
            raise InputError("--postures", f"{item!r} is neither zero/max/min nor a "
                             "number in mm") from None
        if not rho_min <= value <= rho_max:
            raise InputError("--postures", f"{value:g} mm is outside the machine's "
                             f"{rho_min:g}..{rho_max:g} mm")
        out.append(value)
    return out


def parse_truth(text: str | None) -> dict[str, float]:
    truth: dict[str, float] = {}
    for item in filter(None, (t.strip() for t in (text or "").split(","))):
        name, _, value = item.partition("=")
        if name not in PARAM_INDEX:
            raise InputError("--assume", f"unknown parameter {name!r} "
                             "(e.g. joint_offset.x, squareness.xy)")
        try:
            truth[name] = float(value)
        except ValueError:
            raise InputError("--assume", f"{item!r} needs a number after '='") from None
    return truth


def plan(
    machine: MachineOption,
    params: Annotated[ParamSet, typer.Option(help="Parameter set to identify.")]
    = ParamSet.offsets,
    postures: Annotated[str, typer.Option(
        help="Postures of each leg's test, in order: zero, max, min or a position in mm.")]
    = "zero,max,min,zero",
    cycles: Annotated[int, typer.Option(min=1, help="Repeats of the postures per leg.")] = 3,
    noise: Annotated[float | None, typer.Option(
        help="Gauge noise sigma in mm (default: the machine file's repeatability, "
             "else its resolution).")] = None,
    assume: Annotated[str | None, typer.Option(
        help="Geometry to predict at, parameters in mm or mrad separated by commas, e.g. "
             "'joint_offset.x=0.5, joint_offset.z=-1'.")] = None,
    trials: Annotated[int, typer.Option(
        min=0, help="Monte-Carlo trials of the full nonlinear fit (0: analytic only).")]
    = 10000,
    seed: Annotated[int, seed_option("Seed of the simulated noise.")] = 0,
    as_json: JsonOption = False,
) -> None:
    """Predict the std of each parameter for a planned campaign."""
    spec = read_machine(machine)
    sigma = noise if noise is not None else (spec.gauge_repeatability_mm
                                            or spec.gauge_resolution_mm)
    if sigma <= 0:
        raise InputError("--noise", f"must be positive, got {sigma:g} mm")
    obs = planned_observations(
        spec, postures=parse_postures(postures, spec.rho_min_mm, spec.rho_max_mm),
        cycles=cycles)
    pred = predict_accuracy(obs, PARAM_SETS[params.value], sigma, truth=parse_truth(assume),
                            trials=trials, seed=seed, rounding_mm=spec.gauge_resolution_mm)
    if as_json:
        typer.echo(json.dumps(pred.to_json()))
        return
    print_plan(pred, Path(machine).name, postures, cycles)
