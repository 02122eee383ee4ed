"""``ogacq refit``: identify parameters from a saved file (INTERCHANGE.md)."""

from __future__ import annotations

from enum import StrEnum
from pathlib import Path
from typing import Annotated

import typer

from ogacq.cli.options import (
    AcceptEditedOption,
    JsonOption,
    OtherGeometryOption,
    ParamSet,
    PartialOption,
    RecordedMachineOption,
)
from ogacq.errors import InputError
from ogacq.identify.fit import fit
from ogacq.identify.plausibility import check_result
from ogacq.io.loading import load_input
from ogacq.io.machine_file import read_machine
from ogacq.model.parameters import PARAM_SETS


class Method(StrEnum):
    auto = "auto"
    linear = "linear"
    exact = "exact"


class Weighting(StrEnum):
    ols = "ols"
    gls = "gls"


def refit(
    file: Annotated[Path, typer.Argument(help="Readings CSV, deviations CSV or session.")],
    machine: RecordedMachineOption = None,
    params: Annotated[ParamSet, typer.Option(help="Parameter set to identify.")]
    = ParamSet.offsets,
    method: Annotated[Method, typer.Option(
        help="linear: the papers' eq. 11; exact: nonlinear fit of the exact model. "
             "auto: linear for tabulated deviations, exact for readings.")] = Method.auto,
    weighting: Annotated[Weighting, typer.Option(
        help="Tabulated deviations: ols (the papers') or gls with their covariance "
             "(eq. 13-14). Readings are always weighted by their own noise (the display "
             "rounding that repeats share).")]
    = Weighting.ols,
    other_geometry: OtherGeometryOption = False,
    partial: PartialOption = False,
    accept_edited: AcceptEditedOption = False,
    as_json: JsonOption = False,
) -> None:
    """Identify joint offsets and/or leg lengths from recorded data."""
    spec = read_machine(machine) if machine is not None else None
    names = PARAM_SETS[params.value]
    loaded = load_input(file, spec, names, machine_path=machine, other_geometry=other_geometry,
                        partial=partial, accept_edited=accept_edited)
    obs = loaded.observations
    chosen = method.value
    if chosen == "auto":
        chosen = "linear" if obs.kind == "deviations" else "exact"
    result = fit(obs, names, method=chosen, weighting=weighting.value)
    if not result.converged:
        raise InputError(file, f"the {chosen} fit did not converge "
                         f"({result.stop_reason.describe()}); try --method linear or check "
                         "the data")
    check_result(result)
    if as_json:  # json, or the text rendering below, imported only when used
        import json

        print(json.dumps({**result.to_json(params.value), **loaded.state_json()}))
        return
    from ogacq.cli.render_fit import print_fit, print_notes

    print_notes(loaded.notes())
    print_fit(result, params.value, f"ogacq diagnose {file}"
              + (f" --machine {machine}" if machine is not None else ""))
