"""``ogacq wizard``: the guided calibration for a technician at a terminal."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ogacq_drivers.indicators import DEFAULT_PROTOCOL
from ogacq.cli.options import (
    DEFAULT_SEED,
    DEFAULT_SPEED,
    GaugeProtocol,
    HistoryOption,
    IndicatorCount,
    ProfileChoice,
    seed_option,
)
from ogacq.cli.outputs import check_output_folder
from ogacq.cli.wizard.flow import WizardOptions, run_wizard
from ogacq.sim.faults import parse_fault


def _faults(values: list[str] | None) -> list:
    try:
        return [parse_fault(v) for v in values or []]
    except ValueError as exc:
        raise typer.BadParameter(str(exc), param_hint="--simulate-fault") from None


def wizard(
    simulator: Annotated[bool, typer.Option(
        "--simulator", help="Rehearse on the built-in simulator: its ports are offered as "
                            "the instruments.")] = False,
    seed: Annotated[int, seed_option("Simulator: seed of the hidden offsets (as demo and "
                                     "sim).")] = DEFAULT_SEED,
    speed: Annotated[float, typer.Option(min=1.0, help="Simulator: time speed-up.")
                     ] = DEFAULT_SPEED,
    profile: Annotated[ProfileChoice, typer.Option(
        help="Simulator: controller register map.")] = ProfileChoice["cia402"],
    machine: Annotated[Path | None, typer.Option(
        "--machine", "-m", help="Machine file (asked for when not given).")] = None,
    out: Annotated[Path | None, typer.Option(
        help="Folder for the campaign file and the session (default: a new one named "
             "after the time).")] = None,
    cycles: Annotated[int, typer.Option(min=1, help="Zero/Max/Min/Zero cycles per leg.")] = 3,
    settle_s: Annotated[float, typer.Option(
        min=0.0, help="Longest wait for the machine to come to rest after a move, s.")] = 1.0,
    stability_timeout_s: Annotated[float, typer.Option(
        min=0.1, help="Longest wait for a gauge to give a steady value, s.")] = 10.0,
    gauge_range_mm: Annotated[float, typer.Option(
        min=0.1, help="Plunger travel of the gauges, mm (for the mid-range check).")] = 12.7,
    max_offset_mm: Annotated[float, typer.Option(
        min=0.0, help="Largest joint offset expected, mm (sets the expected reading "
                      "ranges).")] = 2.0,
    by_eye: Annotated[bool, typer.Option(
        "--by-eye", help="Dial indicators read by eye, each reading typed: offered as the "
                         "default answer to 'How are the gauges read?' (without it the "
                         "default is the first protocol listed, or a rehearsal's "
                         "simulated one).")] = False,
    indicators: Annotated[IndicatorCount | None, typer.Option(
        help="6: two per leg, left in place; 2: moved from leg to leg, as in the papers "
             "(asked when not given; a rehearsal's simulator has 6 unless told).")] = None,
    resume: Annotated[Path | None, typer.Option(
        help="Continue this session with the wizard.")] = None,
    gauge_protocol: Annotated[GaugeProtocol, typer.Option(
        help="Simulator: what the simulated gauges speak.")] = GaugeProtocol[DEFAULT_PROTOCOL],
    simulate_fault: Annotated[list[str] | None, typer.Option(
        hidden=True, help="Simulator: GAUGE:KIND@N[xCOUNT], a gauge fault after N "
                          "readings.")] = None,
    history: HistoryOption = None,
) -> None:
    """Guided calibration: connect the instruments, set the gauges leg by leg, measure,
    identify the joint offsets."""
    faults = _faults(simulate_fault)
    if faults and not simulator and resume is None:
        raise typer.BadParameter("faults can only be injected into the simulator",
                                 param_hint="--simulate-fault")
    if out is not None:
        check_output_folder(out, "--out")
    options = WizardOptions(simulator=simulator, seed=seed, speed=speed, profile=profile.value,
                            machine=machine, out=out, cycles=cycles, settle_s=settle_s,
                            stability_timeout_s=stability_timeout_s,
                            gauge_range_mm=gauge_range_mm, max_offset_mm=max_offset_mm,
                            by_eye=by_eye, faults=faults,
                            indicators=int(indicators) if indicators else None,
                            resume=resume, gauge_protocol=gauge_protocol.value,
                            history=history)
    code = run_wizard(options)
    if code:
        raise typer.Exit(code)  # 130: quit, the session kept
