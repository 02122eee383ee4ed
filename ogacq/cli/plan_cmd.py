"""``ogacq plan``: predicted accuracy of a campaign before it is run."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer

from ogacq.cli.options import JsonOption, MachineOption, ParamSet, seed_option
from ogacq.cli.plain import print_wrapped
from ogacq.cli.render import print_plan, trials_progress
from ogacq.errors import InputError
from ogacq.identify.accuracy import planned_observations, predict_accuracy
from ogacq.identify.noise import GaugeNoise
from ogacq.io.machine_file import read_machine
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import PARAM_INDEX, PARAM_SETS, effect_of
from ogacq.model.units import UM_PER_MM
from ogacq.protocol.plan import (
    APPROACHES,
    PlanError,
    ProtocolConfig,
    check_postures,
    scan_targets,
)
from ogacq.protocol.scan_design import design_scan

# The campaign file's own bounds (ogacq/campaign/campaign_file.py: cycles 1..1000, noise_mm
# at most 1 mm, beyond any indicator): a plan predicts a campaign that can be run.
MAX_CYCLES = 1000
MAX_NOISE_MM = 1.0
# Beyond a million trials the Monte-Carlo's own scatter on a std (about 1/sqrt(2 n)) is
# under 0.1 %, far below what the analytic prediction beside it already says; a larger
# number only runs for hours (no source: the project's own bound).
MAX_TRIALS = 1_000_000
# A reading step of a station (move, settle, read two gauges): the issue 37 figure for a
# real machine; no source beyond it (calibrate measures its own from the campaign).
STEP_S = 5.5


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


def parse_range(text: str | None) -> tuple[float | None, float | None]:
    """``FROM:TO`` in mm (either side may be left empty: the machine's travel end)."""
    if text is None:
        return None, None
    low, sep, high = text.partition(":")
    try:
        if sep:
            return (float(low) if low.strip() else None, float(high) if high.strip() else None)
    except ValueError:
        pass
    raise InputError("--scan-range", f"{text!r} is not FROM:TO in mm, e.g. -50:50")


def describe_protocol(protocol: ProtocolConfig, machine: MachineSpec) -> str:
    """The plan in words: its postures, or its scan's range, step and directions."""
    if not protocol.is_scan:
        return "postures " + ",".join(str(p) for p in protocol.postures)
    targets = scan_targets(protocol, machine)
    ways = {"both": "both directions", "sequence": "up and down",
            "from_below": "upwards only", "from_above": "downwards only"}[protocol.approach]
    every = (f"every {protocol.scan_step_mm:g} mm" if protocol.scan_step_mm is not None
             else "at irregular intervals")
    return (f"scan {targets[0]:g}..{targets[-1]:g} mm {every}, "
            f"{ways} ({len(targets)} postures per leg)")


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
        # the geometry is predicted at: within the range a real machine has (the
        # effects table, ogacq/model/parameters.py); 1e308 or nan stopped the SVD
        effect = effect_of(name)
        if not abs(truth[name] - effect.nominal) <= effect.plausible_range:
            raise InputError("--assume", f"{name} = {truth[name]:g} {effect.unit} is beyond "
                             f"what a real machine has ({effect.nominal:g} ± "
                             f"{effect.plausible_range:g} {effect.unit})")
    return truth


@dataclass(frozen=True)
class PlanNoise:
    """The gauge scatter a plan predicts with (before the display's rounding, which the
    prediction adds) and where it came from, in words."""

    scatter_mm: float
    source: str  # "--noise", "machine file", "repeated readings", "display rounding"
    says: str
    # readings rounded to the display step (False: means of values whose rounding the
    # scatter dithered, measured so: their noise holds what is left of it)
    rounded: bool = True

    def to_json(self) -> dict[str, Any]:
        return {"noise_mm": self.scatter_mm, "noise_source": self.source}


def plan_noise(spec: MachineSpec, machine: str, noise: float | None,
               noise_from: Path | None) -> PlanNoise:
    """The noise to predict with: given, measured from the repeats of an earlier
    campaign's readings, stated in the machine file, else none but the display's
    rounding (step / sqrt(12) a reading, shared by the cycles: the prediction's
    ``GaugeNoise.stated(0, step)``). The display step itself is no noise: a gauge
    reads to its step and scatters by what it scatters (issue 38: the plan assumed
    10 µm where the diagnosis measured 2.9 µm, the rounding of a quiet gauge)."""
    step_um = spec.gauge_resolution_mm * UM_PER_MM
    if noise is not None:
        return PlanNoise(noise, "--noise", f"gauge noise {noise * UM_PER_MM:.3g} µm a "
                         "reading (--noise)")
    if noise_from is not None:
        return _measured_noise(spec, noise_from)
    stated = spec.gauge_repeatability_mm
    if stated is not None:
        return PlanNoise(stated, "machine file", f"gauge noise {stated * UM_PER_MM:.3g} µm "
                         f"a value, stated in {machine} (a reading that averages several "
                         "values scatters less: --noise-from an earlier session measures "
                         "it)")
    return PlanNoise(0.0, "display rounding", (
        f"gauge noise not stated in {machine} (gauge_repeatability_mm) nor given: "
        f"predicted for the {step_um:g} µm display step's rounding alone "
        f"({step_um / math.sqrt(12.0):.2g} µm a reading, every cycle rounding alike: a "
        "gauge far quieter than its step), without a Monte-Carlo (its trials would all "
        "round alike); --noise MM or --noise-from an earlier session for the gauge's own"))


def _measured_noise(spec: MachineSpec, path: Path) -> PlanNoise:
    """The gauge scatter the repeats of an earlier campaign's readings show (a session,
    its own machine's display; a readings CSV, this machine's), whatever its machine
    file states."""
    from ogacq.identify.noise import noise_for
    from ogacq.io.loading import load_input
    from ogacq.io.tables import sniff

    if not path.exists():
        raise InputError(path, "no such file")
    obs = load_input(path, None if sniff(path) == "session" else spec).observations
    unstated = replace(obs, machine=replace(obs.machine, gauge_repeatability_mm=None))
    found = noise_for(unstated)
    if not found.measured or found.scatter_mm is None:
        raise InputError(path, "holds no repeated readings to measure the gauge noise "
                               "from (each posture read in one cycle, or tabulated "
                               "deviations)")
    if unstated.averaged is not None and unstated.averaged.max() > 1 and found.dithered:
        # means of values the scatter dithers: a reading's whole noise, not rounded again
        return PlanNoise(found.sigma_mm, "repeated readings", (
            f"gauge noise {found.sigma_mm * UM_PER_MM:.2g} µm a reading (the mean of "
            f"{int(np.median(unstated.averaged))} values), measured from the repeats of "
            f"{path} ({found.dof} dof)"), rounded=False)
    return PlanNoise(found.scatter_mm, "repeated readings", (
        f"gauge noise {found.scatter_mm * UM_PER_MM:.2g} µm a reading, measured from "
        f"the repeats of {path} ({found.dof} dof)"))


def _checked_noise(spec: MachineSpec, machine: Path | str, noise: float | None,
                   noise_from: Path | None) -> PlanNoise:
    """The plan's noise, refused (naming the option or file) where no gauge has it."""
    if noise is not None and noise_from is not None:
        raise InputError("--noise-from", "give the noise (--noise) or where to measure it "
                                         "(--noise-from), not both")
    gauge = plan_noise(spec, Path(machine).name, noise, noise_from)
    sigma = gauge.scatter_mm
    if not 0 <= sigma <= MAX_NOISE_MM or (sigma == 0 and gauge.source == "--noise"):
        raise InputError("--noise" if noise is not None else noise_from or machine,
                         f"the gauge noise must be above 0 and at most {MAX_NOISE_MM:g} mm "
                         f"(beyond any indicator), got {sigma:g} mm")
    return gauge


def _planned_protocol(spec: MachineSpec, postures: str, cycles: int, approach: str,
                      scan_step: float | None, scan_range: str | None) -> ProtocolConfig:
    """The campaign the plan predicts, its options checked against the machine."""
    if approach not in APPROACHES:
        raise InputError("--approach", f"{approach!r} is not one of {', '.join(APPROACHES)}")
    if scan_step is None and scan_range is not None:
        raise InputError("--scan-range", "needs --scan-step (the step of the scan)")
    start, end = parse_range(scan_range)
    try:
        protocol = ProtocolConfig(
            postures=tuple(parse_postures(postures, spec.rho_min_mm, spec.rho_max_mm)),
            cycles=cycles, approach=approach, scan_step_mm=scan_step, scan_from_mm=start,
            scan_to_mm=end)
        check_postures(protocol, spec)
    except PlanError as exc:
        raise InputError("--scan-step" if scan_step is not None else "--postures",
                         str(exc)) from None
    return protocol


def plan(
    machine: MachineOption,
    params: Annotated[ParamSet, typer.Option(help="Parameter set to identify.")]
    = ParamSet.offsets,
    postures: Annotated[str, typer.Option(
        help="Postures of each leg's test, in order: zero, max, min or a position in mm.")]
    = "zero,max,min,zero",
    cycles: Annotated[int, typer.Option(min=1, max=MAX_CYCLES,
                                        help="Repeats of the postures per leg.")] = 3,
    scan_step: Annotated[float | None, typer.Option(
        help="A scan instead of --postures: a reading every this many mm along each "
             "leg's axis, up and back down.")] = None,
    scan_range: Annotated[str | None, typer.Option(
        help="The scan's FROM:TO in mm (default: the machine's whole travel).")] = None,
    approach: Annotated[str, typer.Option(
        help="How each posture is approached: sequence, from_below, from_above, both.")]
    = "sequence",
    noise: Annotated[float | None, typer.Option(
        help="Gauge noise sigma in mm, the display's rounding added (default: "
             "--noise-from, else the machine file's gauge_repeatability_mm, else the "
             "rounding alone, a floor).")] = None,
    noise_from: Annotated[Path | None, typer.Option(
        help="An earlier campaign's session or readings CSV: predict with the gauge noise "
             "its repeats show.")] = None,
    assume: Annotated[str | None, typer.Option(
        help="Geometry to predict at, parameters in mm or mrad separated by commas, e.g. "
             "'joint_offset.x=0.5, joint_offset.z=-1'.")] = None,
    trials: Annotated[int, typer.Option(
        min=0, max=MAX_TRIALS,
        help="Monte-Carlo trials of the full nonlinear fit (0: analytic only).")]
    = 10000,
    seed: Annotated[int, seed_option("Seed of the simulated noise.")] = 0,
    scan_minutes: Annotated[float | None, typer.Option(
        min=1.0, help="Also show the separating scan `ogacq calibrate` would design for "
                      "this machine within this much machine time (its targets, the band "
                      "of leads it resolves, its detection limit per family).")] = None,
    step_s: Annotated[float, typer.Option(
        min=0.1, help="With --scan-minutes: the machine time of a reading step (a campaign "
                      "on the machine measures its own).")] = STEP_S,
    as_json: JsonOption = False,
) -> None:
    """Predict the std of each parameter for a planned campaign."""
    spec = read_machine(machine)
    gauge = _checked_noise(spec, machine, noise, noise_from)
    sigma = gauge.scatter_mm
    protocol = _planned_protocol(spec, postures, cycles, approach, scan_step, scan_range)
    obs = planned_observations(spec, protocol=protocol)
    if sigma == 0:  # the rounding alone: the analytic floor, no trials to draw
        trials = 0
    with trials_progress("Monte-Carlo trials of the nonlinear fit") as on_trials:
        pred = predict_accuracy(obs, PARAM_SETS[params.value], sigma,
                                truth=parse_truth(assume), trials=trials, seed=seed,
                                rounding_mm=spec.gauge_resolution_mm if gauge.rounded
                                else None, on_trials=on_trials)
    # with no scatter known, the design's detection limits are at the rounding's noise
    design_noise = sigma or GaugeNoise.stated(0.0, spec.gauge_resolution_mm).sigma_mm
    design = None if scan_minutes is None else design_scan(
        spec, protocol, noise_mm=design_noise, seconds_per_step=step_s,
        budget_s=scan_minutes * 60)
    if as_json:
        extra = {"separating_design": design.to_json()} if design is not None else {}
        typer.echo(json.dumps(pred.to_json() | gauge.to_json()
                              | {"protocol": protocol.to_dict()} | extra))
        return
    print_plan(pred, Path(machine).name, describe_protocol(protocol, spec), cycles, gauge.says)
    if design is not None:
        typer.echo("separating scan `ogacq calibrate` would design (ISO 230-2 4.3.2):")
        for line in design.lines():  # wrapped at the width: a 200-character line was cut
            print_wrapped(f"  {line}")
