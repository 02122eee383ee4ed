"""``ogacq positioning``: an axis's positioning tested by its scale (ISO 230-2)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from ogacq.calibration.drive_step import drive_step_mm
from ogacq.campaign.campaign_file import read_campaign
from ogacq.campaign.positioning import positioning_document, run_positioning, write_document
from ogacq.cli.campaign_cmds import said_if_stopped
from ogacq.cli.options import JsonOption
from ogacq.cli.outputs import check_output_file
from ogacq.cli.plain import plain
from ogacq.cli.render import campaign_progress
from ogacq.errors import InputError
from ogacq.model.units import UM_PER_MM
from ogacq.protocol.positioning import ISO_RUNS, positioning_plan
from ogacq.session.store import load_session


def positioning(
    campaign_file: Annotated[Path, typer.Argument(
        help="Campaign file naming the controller and the axis's scale ([axis_scale.x]), "
             "or a [simulator] one.")],
    axis: Annotated[str, typer.Option(help="The axis to test: x, y or z.")] = "x",
    runs: Annotated[int, typer.Option(
        min=2, max=50, help="Runs in each direction (ISO 230-2: five).")] = ISO_RUNS,
    out: Annotated[Path | None, typer.Option(
        help="The test's session (default: positioning-AXIS.jsonl beside the campaign's "
             "session); an unfinished one is continued.")] = None,
    as_json: JsonOption = False,
) -> None:
    """Test an axis's positioning with a scale along its actuator (ISO 230-2:2014):
    irregular targets over the travel, both directions, several runs, only that axis
    moving; prints the accuracy A, repeatability R, reversal B, systematic error E and
    M, and writes them as JSON beside the session.

    Exit 0: measured; 2 no scale declared for the axis or a bad file; 3 a device failed
    (run the same command again to continue); 4 the scale past its certificate's due
    date (the campaign file's [override] expired_gauges runs it all the same)."""
    if axis not in ("x", "y", "z"):
        raise InputError("--axis", f"is x, y or z, got {axis!r}")
    campaign = read_campaign(campaign_file)
    if axis not in campaign.axis_scales:
        what = "an empty one: the simulator serves it" if campaign.simulator is not None \
            else "its protocol and port"
        raise InputError(campaign_file, f"declares no scale along the {axis} axis: add an "
                         f"[axis_scale.{axis}] table ({what})")
    session = out or campaign.session.parent / f"positioning-{axis}.jsonl"
    if out is None:  # the campaign's session folder, made as a campaign makes it
        session.parent.mkdir(parents=True, exist_ok=True)
    check_output_file(session, "--out", force=True)  # an unfinished one is continued
    profile = campaign.simulator.profile if campaign.simulator is not None else \
        campaign.controller.profile if campaign.controller is not None else "cia402"
    step = drive_step_mm(profile)
    plan = positioning_plan(campaign.machine, axis, runs=runs, drive_step_mm=step)
    if session.exists() and load_session(session).header.positioning \
            not in (None, plan.to_json()):
        raise InputError(session, "holds a positioning test of another plan: give --out")
    if not as_json:
        typer.echo(f"{axis} axis: {len(plan.targets_mm)} targets from "
                   f"{min(plan.targets_mm):+g} to {max(plan.targets_mm):+g} mm, {runs} runs "
                   f"each way ({plan.readings} readings); session {plain(str(session))}")
    with campaign_progress(enabled=not as_json) as observer, said_if_stopped(
            "positioning test", "the session is saved: run the same command to continue it"):
        done = run_positioning(campaign, plan, session, observer=observer)
    document = positioning_document(done, step)
    path = write_document(done, document)
    if as_json:
        typer.echo(json.dumps(document))
        return
    typer.echo(f"ISO 230-2 {axis}: " + ", ".join(
        f"{name} {document['iso230_2'][f'{name}_mm'] * UM_PER_MM:.2f} µm" for name in "AEMRB")
        + f" (the drive steps {step * UM_PER_MM:g} µm)")
    typer.echo(f"written: {plain(str(path))}")
