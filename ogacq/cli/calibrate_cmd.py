"""``ogacq calibrate``: from campaign to validated machine (``ogacq.calibration``).

On a station, give the campaign file (its controller and gauges); on the built-in
simulator, ``--simulator`` (with ``--effects``). Everything goes into one folder:
the procedure's log, each campaign's session, the exported tables, the maps file,
the record. A run stopped anywhere continues with ``--resume FOLDER`` (or the same
command with ``--out FOLDER``). It writes to the controller: without a terminal to
confirm on, ``--yes`` is required.
"""

from __future__ import annotations

import dataclasses
import json
import sys
import time
from pathlib import Path
from typing import Annotated

import typer

from ogacq.calibration.log import LOG_NAME, ProcedureLog
from ogacq.calibration.setup import SCAN_MINUTES, Setup, simulator_setup, station_setup
from ogacq.campaign.campaign_file import SimulatorSpec, read_campaign
from ogacq.cli.campaign_cmds import said_if_stopped
from ogacq.cli.options import (
    DEFAULT_SEED,
    DEFAULT_SPEED,
    RUNS_FOLDER,
    HistoryOption,
    JsonOption,
    OverrideExpiredOption,
    ProfileChoice,
    axis_scales_option,
    login_name,
    override_reason,
    scale_axes,
    seed_option,
    simulated_machine,
)
from ogacq.cli.outputs import check_output_folder
from ogacq.cli.plain import plain
from ogacq.errors import InputError, Refused
from ogacq.io.atomic import write_atomically
from ogacq.io.machine_file import machine_text, read_machine
from ogacq.io.names import checked_name
from ogacq.model.machine import PAPER_PROTOTYPE_DIGITAL_NOTE
from ogacq.protocol.positioning import ISO_RUNS
from ogacq.sim.truth import read_effects_text

MACHINE_FILE, EFFECTS_FILE = "machine.toml", "effects.toml"  # --simulator's, in the folder


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
    machine: Annotated[Path | None, typer.Option(
        "--machine", "-m", help="With --simulator: rehearse on this machine file (its legs, "
                                "travel, gauges' display step, screws' leads) instead of the "
                                "papers' prototype; its serial taken as SIM-SEED, so that "
                                "the history keeps the rehearsal apart from the "
                                "machine.")] = None,
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
    scan_step_mm: Annotated[float | None, typer.Option(
        min=0.1, help="A scan every this many mm where a map is suspected, instead of the "
                      "designed one (targets at irregular intervals that sample every lead "
                      "from 2 to 40 mm, or from the shortest the machine file states, and "
                      "each stated one).")] = None,
    scan_minutes: Annotated[float | None, typer.Option(
        min=1.0, help="The machine time the designed separating scan may take (with its "
                      "reading again of a pitch left loose), and the validation scan after "
                      "the write likewise; given (or the campaign file's scan_minutes), the "
                      "scan grows within it toward its detection target (default: "
                      f"{SCAN_MINUTES:g}, the fewest targets that sample every lead).")] = None,
    axis_scales: Annotated[str, axis_scales_option(
        "With --simulator: the axes (e.g. x,y,z) along which a scale is mounted; a map "
        "written on such an axis is validated by ISO 230-2's positioning test over its "
        "whole travel (on a station: the campaign file's [axis_scale.x] tables).")] = "",
    scale_runs: Annotated[int, typer.Option(
        min=2, max=50, help="Runs each way of each axis scale's positioning test "
                            "(ISO 230-2: five).")] = ISO_RUNS,
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
    operator = checked_name(operator, "--operator") if operator is not None else None
    scales = _scale_axes(axis_scales, simulator)
    _simulator_options_only_with_it(simulator, campaign, effects, machine)
    files = _simulator_files(seed, effects, machine) if simulator and resume is None else {}
    folder, resuming = _folder(campaign, simulator, out, resume, files)
    if not yes and not sys.stdin.isatty():
        raise Refused("calibrate writes to the controller and asks first: without a terminal "
                      "to confirm on, give --yes (unattended stations)")
    setup = _resumed_setup(folder) if resuming else _new_setup(
        folder, campaign, files, seed, profile.value, speed, scan_step_mm,
        not no_separate, operator, reason, scan_minutes, scales, scale_runs)
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
        with said_if_stopped("campaign", "the procedure is saved: continue it with `ogacq "
                                         f"calibrate --resume {folder}`"):
            outcome = run_procedure(setup, ui, resume=resuming, history=where)
    finally:
        ui.close()
    report = None
    if outcome.record is not None and outcome.evidence is not None:
        from ogacq.cli.report_cmd import issue_report
        from ogacq.record.scale_tests import axis_scales_section
        from ogacq.session.store import load_session

        # the positioning tests by the axis scales, as the procedure's log holds them
        tested = axis_scales_section(load_session(folder / LOG_NAME))
        record = outcome.record if tested is None else {**outcome.record,
                                                        "axis_scales": tested}
        report, _ = issue_report(
            load_session(outcome.evidence), folder / "report",
            validation=load_session(outcome.validation) if outcome.validation else None,
            diagnosis=_campaign_diagnosis(folder), diagnosis_source=folder / LOG_NAME,
            record=record)
        record_calibrate(outcome.evidence, history, record, outcome.procedure,
                         outcome.details, validation=outcome.validation, location=where)
    if as_json:
        typer.echo(json.dumps({"folder": str(folder), "procedure": outcome.procedure,
                               "outcome": outcome.outcome, "reason": outcome.reason,
                               "report": str(report) if report else None,
                               **outcome.details}))
    print_outcome(outcome, report)
    if outcome.exit_code:
        raise typer.Exit(outcome.exit_code)


def _scale_axes(given: str, simulator: bool) -> tuple[str, ...]:
    """``--axis-scales``'s axes (the simulator's only: a station's are in its file)."""
    axes = scale_axes(given)
    if axes and not simulator:
        raise InputError("--axis-scales", "is the simulator's: on a station, declare each "
                         "scale in the campaign file ([axis_scale.x], its protocol and port)")
    return axes


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
            resume: Path | None, files: dict[str, bytes]) -> tuple[Path, bool]:
    """The procedure's folder, and whether it continues one. ``files``: what this
    command writes into a new folder before its log (a folder a kill left holding
    those alone is started again)."""
    if resume is not None:
        if campaign is not None or simulator or out is not None:
            raise InputError("--resume", "continues a procedure as it was started: give it "
                             "alone (no campaign file, --simulator or --out)")
        if not _has_header(resume / LOG_NAME):
            raise InputError(resume, f"no calibration procedure here (no {LOG_NAME}, or one "
                             "without its header: stopped before it started); start it again "
                             f"with the command that made it and --out {resume}")
        return resume, True
    if (campaign is None) == (not simulator):
        raise InputError("--simulator" if campaign is None else str(campaign),
                         "give a station's campaign file, or --simulator (not both)")
    folder = out or RUNS_FOLDER / f"calibrate-{time.strftime('%Y%m%d-%H%M%S')}"
    check_output_folder(folder, "--out")
    if _has_header(folder / LOG_NAME):
        return folder, True  # the same command again: it continues
    if folder.is_dir() and any(folder.iterdir()):
        _clear_start_up(folder, files)
    return folder, False


def _has_header(log_path: Path) -> bool:
    """Whether the procedure's log holds its whole header (a kill between its creation
    and its first write leaves it empty)."""
    try:
        with open(log_path, "rb") as log_file:
            return log_file.readline().endswith(b"\n")
    except OSError:
        return False


def _clear_start_up(folder: Path, files: dict[str, bytes]) -> None:
    """Start again in a folder a kill in calibrate's first seconds left (issue 36.5):
    it holds only what this same command writes before its log has a header (those
    files as it writes them, a log without its header, a write's temporary), which
    are cleared; anything else refuses the folder."""
    leftovers = []
    for entry in folder.iterdir():
        name = entry.name
        ours = (name in files and entry.is_file() and entry.read_bytes() == files[name]) or \
            (name in (LOG_NAME, f"{LOG_NAME}.lock") and not _has_header(folder / LOG_NAME)) or \
            (name.startswith(".") and name.endswith(".tmp") and entry.is_file())
        if not ours:
            raise InputError(folder, "exists and is not empty (and holds no procedure); "
                             "choose another --out")
        if name not in files:
            leftovers.append(entry)
    for entry in leftovers:
        entry.unlink()


def _simulator_options_only_with_it(simulator: bool, campaign: Path | None,
                                    effects: Path | None, machine: Path | None) -> None:
    if effects is not None and campaign is not None:
        raise InputError("--effects", "is the simulator's: give it with --simulator")
    if machine is not None and not simulator:
        raise InputError("--machine", "is the simulator's: a station's machine file is its "
                         "campaign file's")


def _simulator_files(seed: int, effects: Path | None,
                     machine: Path | None = None) -> dict[str, bytes]:
    """The files ``--simulator`` writes into a new folder: its machine file (the papers'
    prototype, or ``machine``'s under the rehearsal's serial) and a copy of the effects
    file (read once: a pipe can be read only once)."""
    if machine is None:
        spec, note = simulated_machine(seed), PAPER_PROTOTYPE_DIGITAL_NOTE
    else:
        spec = dataclasses.replace(read_machine(machine), serial=simulated_machine(seed).serial)
        note = f"A rehearsal on the simulator of {machine} (its serial the rehearsal's)."
    files = {MACHINE_FILE: machine_text(spec, note).encode("utf-8")}
    if effects is not None:
        files[EFFECTS_FILE] = read_effects_text(effects).encode("utf-8")
    return files


def _new_setup(folder: Path, campaign_path: Path | None, files: dict[str, bytes], seed: int,
               profile: str, speed: float, scan_step_mm: float | None, separate: bool,
               operator: str | None, reason: str, scan_minutes: float | None = None,
               scales: tuple[str, ...] = (), scale_runs: int = ISO_RUNS) -> Setup:
    if campaign_path is not None:
        campaign = read_campaign(campaign_path)
        if campaign.simulator is not None or campaign.controller is None:
            raise InputError(campaign_path, "names the built-in simulator: calibrate it with "
                             "--simulator")
        folder.mkdir(parents=True, exist_ok=True)
        return station_setup(folder, campaign, scan_step_mm=scan_step_mm, separate=separate,
                             scan_minutes=scan_minutes or campaign.scan_minutes,
                             scale_runs=scale_runs)
    folder.mkdir(parents=True, exist_ok=True)
    for name, data in files.items():
        write_atomically(folder / name, data)
    effects_path = (folder / EFFECTS_FILE).resolve() if EFFECTS_FILE in files else None
    # a rehearsal of the procedure, not of the gauges' line timing: the lines at --speed
    spec = SimulatorSpec(seed=seed, effects=effects_path, speed=speed, profile=profile,
                         line_at_speed=True, axis_scales=scales)
    machine_path = (folder / MACHINE_FILE).resolve()
    return simulator_setup(folder, read_machine(machine_path), machine_path,
                           spec, operator=operator or login_name("calibrate"),
                           override_expired=reason, scan_step_mm=scan_step_mm,
                           separate=separate, scan_minutes=scan_minutes,
                           scale_runs=scale_runs)


def _resumed_setup(folder: Path) -> Setup:
    """The setup the procedure was started with, from its log's header."""
    log_ = ProcedureLog.reopen(folder)
    try:
        described = log_.header.procedure or {}
    finally:
        log_.close()
    scan = float(described["scan_step_mm"]) if described.get("scan_step_mm") else None
    minutes = float(described["scan_minutes"]) if described.get("scan_minutes") else None
    separate = bool(described.get("separate", True))
    runs = int(described.get("scale_runs") or ISO_RUNS)
    if described.get("mode") == "station":
        campaign = read_campaign(described["campaign_file"])
        return station_setup(folder, campaign, scan_step_mm=scan, separate=separate,
                             scan_minutes=minutes, scale_runs=runs)
    machine_path = Path(described["machine_file"])
    spec = SimulatorSpec.from_header(described["simulator"])
    return simulator_setup(folder, read_machine(machine_path), machine_path, spec,
                           operator=str(described.get("operator") or login_name("calibrate")),
                           override_expired=str(described.get("override_expired") or ""),
                           scan_step_mm=scan, separate=separate, scan_minutes=minutes,
                           scale_runs=runs)
