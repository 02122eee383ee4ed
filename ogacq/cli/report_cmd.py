"""``ogacq report SESSION``: the calibration record, one HTML page plus PNG figures, its
``record.json`` and, with ``--pdf``, its printout."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from ogacq.cli.options import AcceptEditedOption, PartialOption
from ogacq.cli.outputs import check_output_folder
from ogacq.errors import InputError
from ogacq.history.earlier import earlier_calibrations
from ogacq.io.text import read_text
from ogacq.record.calibration_record import CalibrationRecord
from ogacq.record.context import calibration_context
from ogacq.record.identity import session_digest
from ogacq.session.store import LoadedSession, load_session

if TYPE_CHECKING:  # loaded once the command has said what it does (numpy, matplotlib)
    from ogacq.diagnose.diagnosis import Diagnosis
    from ogacq.record.sections import SessionFile
    from ogacq.report import Report
    from ogacq.report.diagnosis_view import DiagnosisView


def report_command(
    session: Annotated[Path, typer.Argument(help="Session file of a calibration campaign.")],
    after: Annotated[Path | None, typer.Option(
        "--after", help="Session of a validation campaign run after the offsets were "
                        "written back: its measured deviations are shown as 'after'.")] = None,
    diagnosis: Annotated[Path | None, typer.Option(
        "--diagnosis", help="Diagnosis JSON (`ogacq diagnose --json`) to show instead of "
                            "diagnosing the session here.")] = None,
    out: Annotated[Path | None, typer.Option(
        "--out", help="Folder for report.html and the PNG figures (default: "
                      "SESSION-report next to the session).")] = None,
    history: Annotated[str | None, typer.Option(
        "--history", metavar="URL_OR_PATH",
        help="History to plot this machine's earlier calibrations from: an SQLite file or "
             "a PostgreSQL URL (default: $OGACQ_HISTORY, else history.sqlite in ogacq's data "
             "folder; none: no history).")] = None,
    pdf: Annotated[bool, typer.Option(
        "--pdf", help="Also print the page to report.pdf (A4) with a headless Chromium "
                      "(on the PATH, or named by OGACQ_BROWSER); exit 2 when there is none.")
    ] = False,
    partial: PartialOption = False,
    accept_edited: AcceptEditedOption = False,
) -> None:
    """Write the calibration record: report.html (identification, instruments,
    environment, method, results with their uncertainty, acceptance, budget, history,
    then the analysis behind them), record.json with the same record, and the figures."""
    from ogacq.session.state import require_complete, session_notes

    folder = out if out is not None else session.parent / f"{session.stem}-report"
    check_output_folder(folder, "--out")
    calibration = load_session(session, accept_edited=accept_edited)
    validation = load_session(after, accept_edited=accept_edited) if after is not None else None
    check_pair(calibration, validation)
    given = None
    if diagnosis is not None:
        given = _read_diagnosis(diagnosis)
        _diagnosis_view(given, diagnosis)  # a malformed one refused before the work
    # the files read first; then whether they may be reported (the page says so)
    for loaded in (calibration, validation):
        if loaded is not None:
            state = require_complete(loaded, partial)
            for line in session_notes(loaded, state):
                typer.echo(f"ogacq: warning: {loaded.path}: {line}", err=True)
    browser = None
    if pdf:  # before the work: none is exit 2 (the report package: matplotlib)
        from ogacq.report.printing import find_browser, print_pdf

        browser = find_browser()
    # some seconds of work (the analysis's and the figures' libraries loaded, the
    # diagnosis, the budget's Monte-Carlo check, the figures drawn), once the inputs
    # are found good: said on stderr, where the page's path on stdout stays the first
    # line a script reads (it was silent for 15-18 s on a busy machine)
    typer.echo(f"ogacq report: issuing the record of {session}: its diagnosis, uncertainty "
               "budget, Monte-Carlo check and figures", err=True)
    from ogacq.cli.campaign_end import step_lines
    from ogacq.cli.render import print_end, working
    from ogacq.cli.report_next import after_report

    earlier, why = earlier_calibrations(history, calibration)
    raw: dict[str, Any] | None
    if given is not None:
        raw, note = given, None
    else:
        with working(f"diagnosing {calibration.path.name}"):
            raw, note = _diagnose_here(calibration)
    with working("issuing the record: uncertainty budget, Monte-Carlo check, figures"):
        page, report = issue_report(calibration, folder, validation=validation,
                                     diagnosis=raw, diagnosis_note=note,
                                     diagnosis_source=diagnosis or session,
                                     history=earlier, history_why=why)
    typer.echo(str(page))
    if browser is not None:  # after the page is on disk: a failed print loses nothing
        typer.echo(str(print_pdf(page, page.with_suffix(".pdf"), browser)))
    # what to do once it is read: every command ends with the next one (issue 38.5)
    steps = after_report(calibration, validation, CalibrationRecord.from_json(report.record),
                         report.data.identified, report.data.validation_identified)
    print_end(step_lines(steps))


def issue_report(calibration: LoadedSession, folder: Path, *,
                  validation: LoadedSession | None = None,
                  diagnosis: dict[str, Any] | None = None,
                  diagnosis_note: str | None = None,
                  diagnosis_source: Path | None = None,
                  history: list[dict[str, Any]] | None = None,
                  history_why: str | None = None,
                  record: dict[str, Any] | None = None) -> tuple[Path, Report]:
    """Write the report of ``calibration`` into ``folder``: its HTML file, and the report
    written (its data: what the next step is decided from). ``diagnosis`` is the JSON of
    INTERCHANGE.md, read from ``diagnosis_source``; ``history``: the machine's earlier
    calibrations (docs/calibration-record.md 5), ``history_why``: why there are none to
    give; ``record``: the record already built (``ogacq calibrate`` adds its compensation
    to it)."""
    from ogacq.record.document import build_record
    from ogacq.record.revision import issue
    from ogacq.report import RECORD_NAME, build_report, collect, write_report

    view = _diagnosis_view(diagnosis, diagnosis_source or calibration.path) \
        if diagnosis is not None else None
    data = collect(calibration, validation=validation, diagnosis=view,
                   diagnosis_note=diagnosis_note)
    earlier = _earlier_issue(folder / RECORD_NAME)
    if record is None:
        record = build_record(calibration, validation=validation, history=history,
                              history_why=history_why, fit=data.identified,
                              validation_fit=data.validation_identified)
        record = _with_compensation_of(record, earlier)
    # issued beside an earlier issue of the same record: its next revision, or itself
    report = build_report(data, issue(record, earlier))
    return write_report(report, folder), report


def _diagnosis_view(diagnosis: dict[str, Any], source: Path) -> DiagnosisView:
    """The diagnosis JSON read as the page reads it; InputError naming ``source`` and
    the key it lacks."""
    from ogacq.report import DiagnosisFormatError, parse_diagnosis

    try:
        return parse_diagnosis(diagnosis)
    except DiagnosisFormatError as exc:
        raise InputError(source, f"diagnosis: {exc}") from None


def _with_compensation_of(record: dict[str, Any], earlier: bytes | None) -> dict[str, Any]:
    """``record`` with the ``compensation`` (and ``axis_scales``) ``ogacq calibrate``
    put in an earlier issue of it (the same campaign, the same validation session):
    only the procedure knows the maps it wrote and the scales' tests it judged them by,
    so re-issuing its record (``ogacq report ... --pdf`` into its folder) must not drop
    them (it issued a revision saying "removed compensation")."""
    new = CalibrationRecord.from_json(record)
    try:
        old = CalibrationRecord.from_json(json.loads(earlier)) if earlier is not None \
            else None
        if old is None or not old.compensation or new.compensation is not None \
                or old.id != new.id or old.session_file.sha256 != new.session_file.sha256 \
                or _sha(old.validation_session_file) != _sha(new.validation_session_file):
            return record
    except (ValueError, TypeError, AttributeError):  # not a record of this version
        return record
    return {**record, "compensation": dict(old.compensation),
            **({"axis_scales": dict(old.axis_scales)} if old.axis_scales else {})}


def _sha(reference: SessionFile | None) -> str | None:
    return reference.sha256 if reference is not None else None


def check_pair(calibration: LoadedSession, validation: LoadedSession | None) -> None:
    """A campaign's session, and with ``--after`` another one of the same machine run
    after it (its as-left measurement); InputError naming the file otherwise. It took
    ``ogacq calibrate``'s procedure log as a campaign (refused as partial, exit 4), an
    axis's positioning test as a campaign that identified nothing, and the campaign
    itself or another machine's as its validation."""
    from ogacq.protocol.positioning import SESSION_KIND

    for loaded, what in ((calibration, "SESSION"), (validation, "--after")):
        if loaded is not None and loaded.header.procedure is not None:
            raise InputError(loaded.path, f"is the log of an `ogacq calibrate` procedure, not "
                             f"a campaign's session: give {what} the calibration.jsonl or "
                             "validation.jsonl beside it (its record is in report/)")
        if loaded is not None and loaded.header.kind == SESSION_KIND:
            raise InputError(loaded.path, "is an axis's positioning test by its scale (ogacq "
                             "positioning), not a campaign of the legs: its ISO 230-2 figures "
                             f"are in {loaded.path.with_suffix('.json').name} beside it; in "
                             "ogacq calibrate, its record holds them (report/)")
    if validation is None:
        return
    if session_digest(validation)[0] == session_digest(calibration)[0]:
        raise InputError(validation.path, "--after is the calibration campaign itself: give "
                         "the validation campaign run after the write-back")
    found, left = calibration_context(calibration), calibration_context(validation)
    if found.machine_serial and left.machine_serial \
            and found.machine_serial != left.machine_serial:
        raise InputError(validation.path, f"--after is a campaign of machine serial "
                         f"{left.machine_serial}, the calibration's is {found.machine_serial}")


def _earlier_issue(path: Path) -> bytes | None:
    """The record.json already in the report's folder (None: none, or unreadable)."""
    try:
        return path.read_bytes()
    except OSError:
        return None


def report_of(session: Path, folder: Path, validation: Path | None = None,
              history: str | None = None) -> tuple[Path, dict[str, Any]]:
    """What ``ogacq report SESSION [--after VALIDATION] --out FOLDER [--history H]``
    writes, the session diagnosed here: the page and the record issued."""
    calibration = load_session(session)
    after = load_session(validation) if validation is not None else None
    earlier, why = earlier_calibrations(history, calibration)
    raw, note = _diagnose_here(calibration)
    page, report = issue_report(calibration, folder, validation=after, diagnosis=raw,
                                 diagnosis_note=note, diagnosis_source=session,
                                 history=earlier, history_why=why)
    return page, json.loads(report.record_json())  # as record.json holds it


def report_diagnosis(result: Diagnosis, session: LoadedSession) -> dict[str, Any]:
    """The diagnosis JSON of INTERCHANGE.md and, beyond that contract, which measurement
    would separate each effect from its alternatives, and the caveats, in the
    diagnosis's own words."""
    data = result.to_json()
    machine_file = session.header.machine_file or "M.toml"
    # the effects found, then (when the fit is not within the noise) "unexplained"
    named = data["effects"][:len(result.effects)]
    for entry, effect in zip(named, result.effects, strict=True):
        entry["separated_by"] = [s.describe().replace("M.toml", machine_file)
                                 for s in effect.separations] + [
            p.describe(machine_file) for p in result.proposals
            if effect.name in (p.first, p.second)]
    data["caveats"] = result.caveats()
    if "proposals" in data:  # the scans with the session's machine file
        data["proposals"] = [p.to_json(machine_file) for p in result.proposals]
    return data


def _read_diagnosis(path: Path) -> dict:
    try:
        text = read_text(path)
    except OSError as exc:
        raise InputError(path, f"cannot read the diagnosis: {exc.strerror or exc}") from None
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(path, f"not JSON ({exc.msg}); expected the output of "
                         "`ogacq diagnose --json`", exc.lineno) from None


def _diagnose_here(session: LoadedSession) -> tuple[dict[str, Any] | None, str | None]:
    """The diagnosis of the session's readings, or (None, why there is none)."""
    from ogacq.diagnose.diagnosis import DiagnosisError, diagnose
    from ogacq.session.convert import session_observations

    if not session.readings:
        return None, "no diagnosis: the session holds no readings"
    try:
        result = diagnose(session_observations(session))
    except (DiagnosisError, ValueError, ArithmeticError) as exc:
        return None, f"the diagnosis could not run on this session: {exc}"
    return report_diagnosis(result, session), None
