"""``ogacq calibrate``: from campaign to validated machine (``ogacq.calibration``).

On a station, give the campaign file (its controller and gauges); on the built-in
simulator, ``--simulator`` (with ``--effects``). Everything goes into one folder:
the procedure's log, each campaign's session, the exported tables, the maps file,
the record. A run stopped anywhere continues with ``--resume FOLDER`` (or the same
command with ``--out FOLDER``). It writes to the controller: without a terminal to
confirm on, ``--yes`` is required.
"""

from __future__ import annotations

import datetime
import getpass
import json
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Annotated

import typer

from ogacq.calibration.log import LOG_NAME, ProcedureLog
from ogacq.calibration.setup import SCAN_STEP_MM, Setup, simulator_setup, station_setup
from ogacq.campaign.campaign_file import SimulatorSpec, read_campaign
from ogacq.cli.options import (
    DEFAULT_SEED,
    DEFAULT_SPEED,
    HistoryOption,
    JsonOption,
    OverrideExpiredOption,
    ProfileChoice,
    override_reason,
    seed_option,
)
from ogacq.cli.outputs import check_output_folder
from ogacq.cli.plain import plain
from ogacq.errors import InputError, Refused
from ogacq.io.machine_file import read_machine, write_machine
from ogacq.model.machine import PAPER_PROTOTYPE_DIGITAL, PAPER_PROTOTYPE_DIGITAL_NOTE
from ogacq.model.tolerances import Tolerances
from ogacq.protocol.runner import CampaignStopped
from ogacq.sim.truth import read_effects_text

RUNS_FOLDER = Path("ogacq-runs")
SIM_TOLERANCE_MM = 0.020  # the rehearsal's acceptance, as `ogacq demo` states it (no source)


def calibrate(
    campaign: Annotated[Path | None, typer.Argument(
        help="Campaign file of the station (controller, gauges, plan); leave out with "
             "--simulator or --resume.")] = None,
    simulator: Annotated[bool, typer.Option(
        "--simulator", help="Calibrate the built-in simulated machine.")] = False,
    effects: Annotated[Path | None, typer.Option(
        help="With --simulator: TOML file of the hidden effects (format: docs/formats.md, "
             "\"Effects file\").")] = None,
    seed: Annotated[int, seed_option("With --simulator: seed of the hidden offsets and the "
                                     "noise.")] = DEFAULT_SEED,
    profile: Annotated[ProfileChoice, typer.Option(
        help="With --simulator: its controller register map.")] = ProfileChoice["cia402"],
    speed: Annotated[float, typer.Option(min=1.0, help="With --simulator: simulated time "
                                                       "speed-up.")] = DEFAULT_SPEED,
    out: Annotated[Path | None, typer.Option(
        help="The procedure's folder (default: a new folder in ./ogacq-runs named "
             "calibrate-DATE-TIME); "
             "one holding a procedure continues it.")] = None,
    resume: Annotated[Path | None, typer.Option(
        "--resume", metavar="FOLDER", help="Continue the procedure in FOLDER where it "
                                           "stopped.")] = None,
    yes: Annotated[bool, typer.Option(
        "--yes", "-y", help="Write without asking (unattended stations).")] = False,
    scan_step_mm: Annotated[float, typer.Option(
        min=0.1, help="Step of the scan run where a map is suspected (mm).")] = SCAN_STEP_MM,
    no_separate: Annotated[bool, typer.Option(
        "--no-separate", help="Do not run the separating measurement an ambiguous "
                              "diagnosis asks for (it is still shown).")] = False,
    operator: Annotated[str | None, typer.Option(
        help="Who calibrates, as the record names them (default: your login name on the "
             "simulator, the campaign file's on a station).")] = None,
    override_expired: OverrideExpiredOption = None,
    history: HistoryOption = None,
    as_json: JsonOption = False,
) -> None:
    """Calibrate the machine and validate it: campaign, diagnosis, the separating
    measurement when the diagnosis is ambiguous, offsets and error maps written (shown,
    confirmed, read back, audited), the compensation tables in the controllers' formats
    with their ISO 230-2 figures, a validation campaign, the record as found and as
    left; the previous state restored when the validation is worse, with the reason.

    Exit 0: validated, kept, or nothing to correct; 1 declined; 3 a campaign stopped
    (resume it); 4 refused, or the write restored after a worse validation.
    """
    reason = override_reason(override_expired)
    folder, resuming = _folder(campaign, simulator, out, resume)
    if not yes and not sys.stdin.isatty():
        raise Refused("calibrate writes to the controller and asks first: without a terminal "
                      "to confirm on, give --yes (unattended stations)")
    setup = _resumed_setup(folder) if resuming else _new_setup(
        folder, campaign, simulator, effects, seed, profile.value, speed, scan_step_mm,
        not no_separate, operator, reason)
    from ogacq.calibration.procedure import calibrate as run_procedure
    from ogacq.cli.render_calibrate import TerminalUI, print_outcome
    from ogacq.history.recording import procedure_history, record_calibrate, record_writebacks

    typer.echo(f"calibration in {plain(folder)}/" + (" (continued)" if resuming else ""),
               err=not sys.stdout.isatty())
    spec = setup.controller
    where = procedure_history(history, folder / "calibration.jsonl")
    ui = TerminalUI(yes=yes, on_recorded=lambda path: record_writebacks(path, history, where),
                    where="the simulator" if setup.simulated else spec.endpoints(),
                    offsets_file=str(spec.offsets_file) if spec.offsets_file else None)
    try:
        outcome = run_procedure(setup, ui, resume=resuming)
    except CampaignStopped as stop:
        typer.echo(f"ogacq: campaign {stop.status}: {plain(stop.reason)}", err=True)
        typer.echo(f"ogacq: the procedure is saved: continue it with `ogacq calibrate "
                   f"--resume {folder}`", err=True)
        raise typer.Exit(stop.exit_code) from None
    finally:
        ui.close()
    report = None
    if outcome.record is not None and outcome.evidence is not None:
        from ogacq.cli.report_cmd import write_session_report
        from ogacq.session.store import load_session

        report = write_session_report(
            load_session(outcome.evidence), folder / "report",
            validation=load_session(outcome.validation) if outcome.validation else None,
            diagnosis=_campaign_diagnosis(folder), diagnosis_source=folder / LOG_NAME,
            record=outcome.record)
        record_calibrate(outcome.evidence, history, outcome.record, outcome.procedure,
                         outcome.details, validation=outcome.validation, location=where)
    if as_json:
        typer.echo(json.dumps({"folder": str(folder), "procedure": outcome.procedure,
                               "outcome": outcome.outcome, "reason": outcome.reason,
                               "report": str(report) if report else None,
                               **outcome.details}))
    print_outcome(outcome, report)
    if outcome.exit_code:
        raise typer.Exit(outcome.exit_code)


def _campaign_diagnosis(folder: Path) -> dict | None:
    """The diagnosis the procedure made of its calibration campaign (its log's), for
    the record's Diagnosis section: without it the record said "no diagnosis was
    given" of a campaign whose diagnosis chose the maps it states."""
    from ogacq.session.records import CalibrateRecord
    from ogacq.session.store import load_session

    for step in reversed(load_session(folder / LOG_NAME).of_type(CalibrateRecord)):
        if step.step == "diagnosis" and step.details.get("role") == "calibration":
            found = step.details.get("diagnosis")
            return found if isinstance(found, dict) else None
    return None


def _folder(campaign: Path | None, simulator: bool, out: Path | None,
            resume: Path | None) -> tuple[Path, bool]:
    if resume is not None:
        if campaign is not None or simulator or out is not None:
            raise InputError("--resume", "continues a procedure as it was started: give it "
                             "alone (no campaign file, --simulator or --out)")
        if not (resume / LOG_NAME).is_file():
            raise InputError(resume, f"no calibration procedure here (no {LOG_NAME})")
        return resume, True
    if (campaign is None) == (not simulator):
        raise InputError("--simulator" if campaign is None else str(campaign),
                         "give a station's campaign file, or --simulator (not both)")
    folder = out or RUNS_FOLDER / f"calibrate-{time.strftime('%Y%m%d-%H%M%S')}"
    check_output_folder(folder, "--out")
    if (folder / LOG_NAME).is_file():
        return folder, True  # the same command again: it continues
    if folder.is_dir() and any(folder.iterdir()):
        raise InputError(folder, "exists and is not empty (and holds no procedure); choose "
                         "another --out")
    return folder, False


def _login_name() -> str:
    try:
        return getpass.getuser()
    except (KeyError, OSError):
        return "calibrate"


def _new_setup(folder: Path, campaign_path: Path | None, simulator: bool,
               effects: Path | None, seed: int, profile: str, speed: float,
               scan_step_mm: float, separate: bool, operator: str | None,
               reason: str) -> Setup:
    if campaign_path is not None:
        if effects is not None:
            raise InputError("--effects", "is the simulator's: give it with --simulator")
        campaign = read_campaign(campaign_path)
        if campaign.simulator is not None or campaign.controller is None:
            raise InputError(campaign_path, "names the built-in simulator: calibrate it with "
                             "--simulator")
        folder.mkdir(parents=True, exist_ok=True)
        setup = station_setup(folder, campaign, scan_step_mm=scan_step_mm, separate=separate)
        return setup
    effects_text = read_effects_text(effects) if effects is not None else None
    folder.mkdir(parents=True, exist_ok=True)
    machine = replace(PAPER_PROTOTYPE_DIGITAL, serial=f"SIM-{seed}",
                      tolerances=Tolerances(default_mm=SIM_TOLERANCE_MM))
    machine_path = write_machine(folder / "machine.toml", machine, PAPER_PROTOTYPE_DIGITAL_NOTE)
    effects_path = None
    if effects_text is not None:
        effects_path = (folder / "effects.toml").resolve()
        effects_path.write_text(effects_text, encoding="utf-8")
    spec = SimulatorSpec(seed=seed, effects=effects_path, speed=speed, profile=profile)
    return simulator_setup(folder, machine, machine_path.resolve(), spec,
                           operator=(operator or _login_name()).strip(),
                           override_expired=reason, scan_step_mm=scan_step_mm,
                           separate=separate, today=datetime.date.today())


def _resumed_setup(folder: Path) -> Setup:
    """The setup the procedure was started with, from its log's header."""
    log_ = ProcedureLog.reopen(folder)
    try:
        described = log_.header.procedure or {}
    finally:
        log_.close()
    scan = float(described.get("scan_step_mm") or SCAN_STEP_MM)
    separate = bool(described.get("separate", True))
    if described.get("mode") == "station":
        campaign = read_campaign(described["campaign_file"])
        return station_setup(folder, campaign, scan_step_mm=scan, separate=separate)
    machine_path = Path(described["machine_file"])
    spec = SimulatorSpec.from_header(described["simulator"])
    return simulator_setup(folder, read_machine(machine_path), machine_path, spec,
                           operator=str(described.get("operator") or _login_name()),
                           override_expired=str(described.get("override_expired") or ""),
                           scan_step_mm=scan, separate=separate)
