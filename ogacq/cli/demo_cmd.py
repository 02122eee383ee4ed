"""``ogacq demo``: a whole calibration against the built-in simulator -- campaign,
identification, diagnosis and report -- in a new folder."""

from __future__ import annotations

import datetime
import json
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Annotated

import typer

from ogacq.campaign.campaign_file import Campaign, SimulatorSpec, campaign_text, read_campaign
from ogacq.campaign.run import run_campaign
from ogacq.campaign.traceability import simulated_gauges
from ogacq.cli.campaign_cmds import execute
from ogacq.cli.campaign_end import NextStep, campaign_end
from ogacq.cli.options import (
    DEFAULT_SEED,
    DEFAULT_SPEED,
    RUNS_FOLDER,
    HistoryOption,
    OverrideExpiredOption,
    ProfileChoice,
    login_name,
    override_reason,
    seed_option,
    simulated_machine,
)
from ogacq.cli.outputs import check_output_folder
from ogacq.cli.plain import Printer, shown
from ogacq.cli.render import print_demo_diagnosis, print_end, print_outcome
from ogacq.cli.report_cmd import issue_report, report_diagnosis
from ogacq.diagnose.diagnosis import diagnose
from ogacq.errors import InputError, Refused
from ogacq.history.recording import record_campaign
from ogacq.io.atomic import write_atomically
from ogacq.io.dates import parse_moment
from ogacq.io.machine_file import write_machine
from ogacq.io.names import checked_name
from ogacq.model.machine import PAPER_PROTOTYPE_DIGITAL_NOTE
from ogacq.protocol.plan import ProtocolConfig
from ogacq.session.convert import export_readings, session_observations
from ogacq.session.store import load_session
from ogacq.sim.truth import read_effects_text


def demo(
    effects: Annotated[Path | None, typer.Option(
        help="TOML file of hidden effects the simulated machine has (format: "
             "docs/formats.md, \"Effects file\").")]
    = None,
    seed: Annotated[int, seed_option("Seed of the hidden offsets and the noise (the same "
                                     "default in demo, sim and wizard).")] = DEFAULT_SEED,
    profile: Annotated[ProfileChoice, typer.Option(
        help="Controller register map of the simulated machine.")] = ProfileChoice["cia402"],
    out: Annotated[Path | None, typer.Option(help="Folder to write (default: a new folder "
                                             "in ./ogacq-runs named demo-DATE-TIME).")] = None,
    speed: Annotated[float, typer.Option(min=1.0, help="Simulated time speed-up.")] = DEFAULT_SPEED,
    history: HistoryOption = None,
    date: Annotated[str | None, typer.Option(
        metavar="YYYY-MM-DD[THH:MM]",
        help="Rehearse the campaign on this date (the simulated indicators' certificates "
             "run a year from 90 days before today).")] = None,
    ambient_c: Annotated[float, typer.Option(
        "--ambient-c", min=-40.0, max=80.0,
        help="The simulated shop's temperature, degC: the legs expand with it.")] = 20.0,
    override_expired: OverrideExpiredOption = None,
    operator: Annotated[str | None, typer.Option(
        help="Who runs the rehearsal, as the record names them (default: your login "
             "name).")] = None,
    loop: Annotated[bool, typer.Option(
        "--loop/--no-loop", help="Then close the loop as `ogacq calibrate` does: write the "
                                 "offsets (and maps), validate, restore when worse "
                                 "(in FOLDER/calibrate).")] = True,
) -> None:
    """A full calibration campaign against the built-in simulator: identify the hidden
    joint offsets through the real drivers and compare them with the truth; then write
    them (and the error maps a table would hold), validate with a second campaign and
    keep or restore them, as `ogacq calibrate` does."""
    reason = override_reason(override_expired)
    rehearsed = None if date is None else parse_moment(date, source=None, key="--date",
                                                       zone=False)
    folder = out or RUNS_FOLDER / f"demo-{time.strftime('%Y%m%d-%H%M%S')}"
    if folder.is_dir() and any(folder.iterdir()):
        raise InputError(folder, "exists and is not empty; choose another --out")
    check_output_folder(folder, "--out")
    # Read now, as text: a process substitution (a pipe) can be read only once.
    effects_text = read_effects_text(effects) if effects is not None else None
    operator_name = checked_name(operator or login_name("demo"), "--operator")
    folder.mkdir(parents=True, exist_ok=True)
    machine = simulated_machine(seed)
    machine_path = write_machine(folder / "machine.toml", machine,
                                 PAPER_PROTOTYPE_DIGITAL_NOTE)
    effects_path = None
    if effects_text is not None:
        effects_path = folder / "effects.toml"
        write_atomically(effects_path, effects_text.encode("utf-8"))
    write_atomically(folder / "campaign.toml", campaign_text(Campaign(
        folder / "campaign.toml", machine, machine_path,
        folder / "session.jsonl", ProtocolConfig(settle_s=1.0),
        gauges=simulated_gauges(datetime.date.today()),
        # a rehearsal of the procedure, not of the gauges' line timing: the lines at
        # --speed, as calibrate --simulator runs them
        simulator=SimulatorSpec(seed=seed, effects=effects_path, speed=speed,
                                profile=profile.value, date=rehearsed,
                                ambient_c=ambient_c, line_at_speed=True),
        override_expired=reason, operator=operator_name),
        comment="written by `ogacq demo`").encode("utf-8"))
    typer.echo(f"demo: simulated machine (seed {seed}, {profile.value}), campaign in {folder}/",
               err=not sys.stdout.isatty())
    campaign = read_campaign(folder / "campaign.toml")
    try:
        outcome = execute(lambda obs: run_campaign(campaign, observer=obs), campaign.session)
    except Refused:
        # refused before anything started (an expired gauge): the folder is left as found
        for name in ("machine.toml", "effects.toml", "campaign.toml"):
            (folder / name).unlink(missing_ok=True)
        if not any(folder.iterdir()):
            folder.rmdir()
        raise
    session = load_session(outcome.session_path)
    export_readings(session, folder / "readings.csv")
    write_atomically(folder / "result.json", (json.dumps(
        {**outcome.fit.to_json("offsets"), "hidden": outcome.hidden}, indent=2) + "\n")
        .encode("utf-8"))
    report = folder / "report" / "report.html"
    end = campaign_end(outcome.session_path, outcome.fit, simulated=True, report=report)
    print_outcome(outcome, end.record)
    # The rest of the story when the joint offsets alone do not fit: what the
    # diagnosis finds, beside the simulator's hidden truth; the report shows the same.
    diagnosis = diagnose(session_observations(session))
    write_atomically(folder / "diagnosis.json",
                     (json.dumps(diagnosis.to_json(), indent=2) + "\n").encode("utf-8"))
    print_demo_diagnosis(diagnosis, outcome.hidden or {})
    issue_report(session, folder / "report",  # the record campaign_end built
                 diagnosis=report_diagnosis(diagnosis, session),
                 record=dict(end.built) if end.built is not None else None)
    now = Printer()  # wrapped between words at the terminal's width
    now.print(shown(f"written: {folder}/session.jsonl, readings.csv, result.json, "
                    "diagnosis.json, report/report.html"))
    record_campaign(outcome.session_path, history, say=lambda text: now.print(shown(text)),
                    record=end.built)
    if loop:  # the loop below is what comes next, on the simulator still running
        opened = tuple(s for s in end.steps if s.command.startswith("open "))
        end = replace(end, steps=(*opened, NextStep(
            "", f"closing the loop below: the offsets written, a validation campaign, the "
                f"record as found and as left in {folder}/calibrate/")))
    print_end(end.lines())
    if loop:
        _close_the_loop(folder, campaign, outcome.session_path, history)


def _close_the_loop(folder: Path, campaign: Campaign, session: Path,
                    history: str | None) -> None:
    """The procedure of `ogacq calibrate`, from the campaign just run: the write, the
    validation, the record as found and as left (FOLDER/calibrate)."""
    from ogacq.calibration.procedure import calibrate
    from ogacq.calibration.setup import simulator_setup
    from ogacq.cli.render_calibrate import TerminalUI, print_outcome
    from ogacq.history.recording import procedure_history, record_calibrate, record_writebacks

    assert campaign.simulator is not None
    print_end([f"closing the loop (as `ogacq calibrate` does): write, validate, keep or "
               f"restore, in {folder}/calibrate/"])  # wrapped between words
    setup = simulator_setup(folder / "calibrate", campaign.machine, campaign.machine_path,
                            campaign.simulator, operator=campaign.operator,
                            override_expired=campaign.override_expired)
    setup.folder.mkdir(parents=True, exist_ok=True)
    where = procedure_history(history, session)
    ui = TerminalUI(yes=True, on_recorded=lambda path: record_writebacks(path, history, where),
                    where="the simulator")
    try:
        done = calibrate(setup, ui, resume=False, calibration_session=session)
    finally:
        ui.close()
    report = None
    if done.record is not None and done.evidence is not None:
        report, _ = issue_report(
            load_session(done.evidence), setup.folder / "report",
            validation=load_session(done.validation) if done.validation else None,
            record=done.record)
        record_calibrate(done.evidence, history, done.record, done.procedure, done.details,
                         validation=done.validation, say=typer.echo, location=where)
    print_outcome(done, report)
