"""``ogacq diagnose``: is the identified model within the gauge noise, and if not,
what physics was left out (INTERCHANGE.md)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from ogacq.cli.app import JsonOption, MachineOption, UserError, app
from ogacq.io.loading import load_observations
from ogacq.io.machine_file import read_machine


@app.command(name="diagnose")
def diagnose_command(
    file: Annotated[Path, typer.Argument(help="Readings CSV, deviations CSV or session.")],
    machine: MachineOption,
    as_json: JsonOption = False,
) -> None:
    """Compare the recordings with the identified model; locate and explain a mismatch."""
    spec = read_machine(machine)
    obs = load_observations(file, spec)
    # scipy.stats loads here, not on every ogacq start
    from ogacq.diagnose.diagnosis import DiagnosisError, diagnose

    try:
        result = diagnose(obs)
    except DiagnosisError as exc:
        raise UserError(f"{file}: {exc}") from None
    if as_json:
        typer.echo(json.dumps(result.to_json()))
        return
    from ogacq.cli.render_diagnosis import print_diagnosis

    print_diagnosis(result, machine_file=str(machine))
