"""``ogacq report SESSION``: the calibration report, one HTML file plus PNG figures."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any

import typer

from ogacq.cli.app import UserError, app
from ogacq.io.errors import InputError
from ogacq.session.store import LoadedSession, load_session


def _load(path: Path) -> LoadedSession:
    """A session, or one line saying the file is not one (a readings CSV, say)."""
    try:
        with path.open("rb") as fh:
            first = fh.readline().lstrip()
    except OSError:
        first = b"{"  # let load_session word the problem
    if first and not first.startswith(b"{"):
        raise InputError(path, "not an ogacq session (line 1 is not a JSON record); "
                         "`ogacq report` takes the session.jsonl a campaign wrote", 1)
    return load_session(path)


def _read_diagnosis(path: Path) -> dict:
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise InputError(path, f"cannot read the diagnosis: {exc.strerror or exc}") from None
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(path, f"not JSON ({exc.msg}); expected the output of "
                         "`ogacq diagnose --json`", exc.lineno) from None


def diagnosis_for_report(session: LoadedSession, done: Any = None,
                   ) -> tuple[dict[str, Any] | None, str | None]:
    """The diagnosis JSON of INTERCHANGE.md from the diagnosis package (``done``: the
    session's diagnosis already made), when this installation has it; else
    (None, why). The report's only tie to that package."""
    if not session.readings:
        return None, "no diagnosis: the session holds no readings"
    try:
        from ogacq.diagnose.diagnosis import diagnose
    except ImportError:
        return None, "no diagnosis: this installation has no diagnosis package"
    from ogacq.session.convert import session_observations

    try:
        result = done if done is not None else diagnose(session_observations(session))
    except (ValueError, ArithmeticError) as exc:  # DiagnosisError is a ValueError
        return None, f"the diagnosis could not run on this session: {exc}"
    if not callable(getattr(result, "to_json", None)):
        return None, "no diagnosis: the diagnosis package returns no JSON"
    data = result.to_json()
    # Beyond the JSON contract: which measurement would separate an effect from its
    # alternatives, and the caveats, in the diagnosis's own words.
    machine_file = str(session.header.get("machine_file") or "M.toml")
    for entry, effect in zip(data.get("effects", []), getattr(result, "effects", []),
                             strict=False):
        entry["separated_by"] = [s.describe().replace("M.toml", machine_file)
                                 for s in getattr(effect, "separations", [])]
    caveats = getattr(result, "caveats", None)
    if callable(caveats):
        data["caveats"] = list(caveats())
    return data, None


@app.command(name="report")
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
) -> None:
    """Write the calibration report: deviations before and after, residuals, parameters
    with confidence intervals, identifiability, diagnosis and provenance."""
    calibration = _load(session)
    validation = _load(after) if after is not None else None
    raw, note = (_read_diagnosis(diagnosis), None) if diagnosis is not None else \
        diagnosis_for_report(calibration)
    folder = out if out is not None else session.parent / f"{session.stem}-report"
    write_session_report(calibration, folder, raw, note, validation=validation,
                         diagnosis_file=diagnosis)


def write_session_report(calibration: LoadedSession, folder: Path,
                         diagnosis: dict[str, Any] | None, diagnosis_note: str | None, *,
                         validation: LoadedSession | None = None,
                         diagnosis_file: Path | None = None) -> None:
    """Write the report of a loaded session and its diagnosis JSON; say where."""
    from ogacq.report import (
        DiagnosisFormatError,
        build_report,
        collect,
        parse_diagnosis,
        write_report,
    )

    try:
        view = parse_diagnosis(diagnosis) if diagnosis is not None else None
    except DiagnosisFormatError as exc:
        raise InputError(diagnosis_file or calibration.path, f"diagnosis: {exc}") from None
    data = collect(calibration, validation=validation, diagnosis=view,
                   diagnosis_note=diagnosis_note)
    if folder.exists() and not folder.is_dir():
        raise UserError(f"{folder}: exists and is not a folder; choose another --out")
    typer.echo(str(write_report(build_report(data), folder)))
