"""``ogacq diagnose``: is the identified model within the gauge noise, and if not,
what physics was left out (INTERCHANGE.md)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from ogacq.cli.app import (
    JsonOption,
    OtherGeometryOption,
    RecordedMachineOption,
    UserError,
    app,
)
from ogacq.identify.plausibility import check_result
from ogacq.io.loading import load_observations
from ogacq.io.machine_file import read_machine
from ogacq.model.parameters import PARAM_SETS


@app.command(name="diagnose")
def diagnose_command(
    file: Annotated[Path, typer.Argument(help="Readings CSV, deviations CSV or session.")],
    machine: RecordedMachineOption = None,
    other_geometry: OtherGeometryOption = False,
    as_json: JsonOption = False,
) -> None:
    """Compare the recordings with the identified model; locate and explain a mismatch."""
    spec = read_machine(machine) if machine is not None else None
    obs = load_observations(file, spec, PARAM_SETS["offsets"], machine_path=machine,
                            other_geometry=other_geometry)
    # scipy.stats loads here, not on every ogacq start
    from ogacq.diagnose.diagnosis import DiagnosisError, diagnose

    try:
        result = diagnose(obs)
    except DiagnosisError as exc:
        raise UserError(f"{file}: {exc}") from None
    check_result(result.final_fit)
    if as_json:
        typer.echo(json.dumps(result.to_json()))
        return
    from ogacq.cli.render_diagnosis import print_diagnosis

    print_diagnosis(result, machine_file=str(machine or file))
