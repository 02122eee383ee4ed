"""``ogacq run``, ``ogacq resume`` and ``ogacq demo``: campaigns from the command line."""

from __future__ import annotations

import json
import shutil
import sys
import time
from pathlib import Path
from typing import Annotated

import typer

from ogacq.campaign import CampaignOutcome, resumable_campaign, run_campaign
from ogacq.campaign_file import Campaign, SimulatorSpec, campaign_text, read_campaign
from ogacq.cli.app import app
from ogacq.cli.leg_prompt import operator_for
from ogacq.io.machine_file import write_machine
from ogacq.model.machine import PAPER_PROTOTYPE_DIGITAL, PAPER_PROTOTYPE_DIGITAL_NOTE
from ogacq.protocol.plan import ProtocolConfig
from ogacq.protocol.runner import CampaignStopped
from ogacq.session.store import load_session

EXIT_STOPPED = 3
EXIT_INTERRUPTED = 130


def _execute(start, *, quiet: bool = False) -> CampaignOutcome:
    """Run ``start(observer)`` with progress shown; a stop exits non-zero with its reason."""
    from ogacq.cli.render import campaign_progress

    with campaign_progress(enabled=not quiet) as observer:
        try:
            return start(observer)
        except CampaignStopped as stop:
            typer.echo(f"ogacq: campaign {stop.status}: {stop.reason}", err=True)
            typer.echo("ogacq: the session is saved and can be resumed with `ogacq resume`",
                       err=True)
            raise typer.Exit(EXIT_INTERRUPTED if stop.status == "interrupted"
                             else EXIT_STOPPED) from None


def _finish(outcome: CampaignOutcome, as_json: bool) -> None:
    if as_json:
        typer.echo(json.dumps({"session": str(outcome.session_path),
                               **outcome.fit.to_json("offsets"),
                               "hidden": outcome.hidden}))
        return
    from ogacq.cli.render import print_outcome

    print_outcome(outcome)


@app.command()
def run(
    campaign_file: Annotated[Path, typer.Argument(help="Campaign file (TOML).")],
    as_json: Annotated[bool, typer.Option("--json", help="Print the result as JSON.")] = False,
) -> None:
    """Run a scripted campaign: no operator when the six gauges are mounted, or one
    asked to set them at each leg when indicators move from leg to leg."""
    campaign = read_campaign(campaign_file)
    operator_for(campaign)  # refuses, before anything opens, one that needs an operator
    outcome = _execute(lambda obs: run_campaign(
        campaign, observer=obs, set_gauges=operator_for(campaign, obs)), quiet=as_json)
    _finish(outcome, as_json)


@app.command()
def resume(
    session: Annotated[Path, typer.Argument(help="Session file of an interrupted campaign.")],
    as_json: Annotated[bool, typer.Option("--json", help="Print the result as JSON.")] = False,
) -> None:
    """Continue an interrupted campaign where it stopped."""
    loaded = load_session(session)
    campaign = resumable_campaign(loaded)
    operator_for(campaign)  # refuses, before anything opens, one that needs an operator
    outcome = _execute(lambda obs: run_campaign(
        campaign, resume=loaded, observer=obs, set_gauges=operator_for(campaign, obs)),
        quiet=as_json)
    _finish(outcome, as_json)


@app.command()
def demo(
    effects: Annotated[Path | None, typer.Option(
        help="TOML file of hidden effects the simulated machine has (see `ogacq sim`).")]
    = None,
    seed: Annotated[int, typer.Option(help="Seed of the hidden offsets and the noise.")] = 1,
    profile: Annotated[str, typer.Option(help="cia402 (Modbus TCP) or iai-pcon (RTU).")]
    = "cia402",
    out: Annotated[Path | None, typer.Option(help="Folder to write (default: a new one "
                                             "named after the time).")] = None,
    speed: Annotated[float, typer.Option(min=1.0, help="Simulated time speed-up.")] = 25.0,
) -> None:
    """A full calibration campaign against the built-in simulator: identify the hidden
    joint offsets through the real drivers and compare them with the truth."""
    folder = out or Path(f"ogacq-demo-{time.strftime('%Y%m%d-%H%M%S')}")
    if folder.exists() and any(folder.iterdir()):
        raise typer.BadParameter(f"{folder} exists and is not empty", param_hint="--out")
    folder.mkdir(parents=True, exist_ok=True)
    machine_path = write_machine(folder / "machine.toml", PAPER_PROTOTYPE_DIGITAL,
                                 PAPER_PROTOTYPE_DIGITAL_NOTE)
    if effects is not None:
        effects = Path(shutil.copy(effects, folder / "effects.toml"))
    (folder / "campaign.toml").write_text(campaign_text(Campaign(
        folder / "campaign.toml", PAPER_PROTOTYPE_DIGITAL, machine_path,
        folder / "session.jsonl", ProtocolConfig(settle_s=1.0),
        simulator=SimulatorSpec(seed=seed, effects=effects, speed=speed, profile=profile)),
        comment="written by `ogacq demo`"))
    typer.echo(f"demo: simulated machine (seed {seed}, {profile}), campaign in {folder}/",
               err=not sys.stdout.isatty())
    campaign = read_campaign(folder / "campaign.toml")
    outcome = _execute(lambda obs: run_campaign(campaign, observer=obs))
    from ogacq.session.convert import export_readings

    session = load_session(outcome.session_path)
    export_readings(session, folder / "readings.csv")
    (folder / "result.json").write_text(json.dumps(
        {**outcome.fit.to_json("offsets"), "hidden": outcome.hidden}, indent=2) + "\n")
    _finish(outcome, as_json=False)
    _diagnose_demo(session, outcome, folder)
    from ogacq.cli.report_cmd import report_command

    report_command(outcome.session_path, out=folder / "report")
    typer.echo(f"written: {folder}/session.jsonl, readings.csv, result.json, diagnosis.json, "
               "report/report.html")


def _diagnose_demo(session, outcome: CampaignOutcome, folder: Path) -> None:
    """The rest of the story when the joint offsets alone do not fit: what the
    diagnosis finds, beside the simulator's hidden truth."""
    from ogacq.cli.render import print_demo_diagnosis
    from ogacq.diagnose.diagnosis import diagnose
    from ogacq.session.convert import session_observations

    diagnosis = diagnose(session_observations(session))
    (folder / "diagnosis.json").write_text(json.dumps(diagnosis.to_json(), indent=2) + "\n")
    print_demo_diagnosis(diagnosis, outcome.hidden or {})
