"""The calibration report: one self-contained HTML page plus its figures as PNG files,
and the calibration record it shows as ``record.json``.

    session (+ validation session, + diagnosis JSON)
        -> data.collect: the numbers (the campaign's own identification)
        -> the record (``ogacq-record/1``, built by ogacq.record.document): what the
           page's record sections show, every value of it
        -> figures: matplotlib on the Agg canvas, PNG bytes
        -> page.render_page: HTML with the PNGs embedded as data: URIs

Entry points: :func:`build_report` (in memory) and :func:`write_report` (to a folder).
"""

from __future__ import annotations

import contextlib
import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ogacq.history.plot import history_figure, recorded_calibrations
from ogacq.io.atomic import write_atomically
from ogacq.io.errors import StorageError
from ogacq.model.parameters import AXES
from ogacq.record.calibration_record import CalibrationRecord
from ogacq.record.sections import NamedResult
from ogacq.report.data import FitSummary, ReportData, collect
from ogacq.report.diagnosis_view import DiagnosisFormatError, DiagnosisView, parse_diagnosis
from ogacq.report.figures import (
    FigureFile,
    deviations_figure,
    diagnosis_figure,
    maps_figure,
    parameters_figure,
    png_bytes,
    profiles_figure,
    residuals_figure,
)
from ogacq.report.formatting import um
from ogacq.report.page import render_page
from ogacq.report.record_view import by_name

REPORT_NAME = "report.html"
RECORD_NAME = "record.json"


@dataclass(frozen=True)
class Report:
    data: ReportData
    record: Mapping[str, Any]  # the ogacq-record/1 document the page shows
    figures: tuple[FigureFile, ...]
    html: str

    def record_json(self) -> str:
        return json.dumps(self.record, indent=2, ensure_ascii=False, allow_nan=False) + "\n"


def planned_legs(data: ReportData) -> tuple[str, ...]:
    plan = data.provenance.plan
    if plan is not None and plan.holds("legs") and all(leg in AXES for leg in plan.legs):
        return plan.legs
    return AXES


def figures_for(data: ReportData, record: Mapping[str, Any]) -> tuple[FigureFile, ...]:
    typed = CalibrationRecord.from_json(record)
    out = []
    fit = data.fit
    if data.deviations:
        out.append(FigureFile(
            "deviations.png", "Deviations per leg and posture",
            "Bar charts per leg: the measured deviations at Max and Min before calibration "
            "in mm, and what remains after compensation in micrometres against the gauge "
            "noise band.", png_bytes(deviations_figure(data.deviations, planned_legs(data)))))
    if fit is not None and data.residuals is not None and len(data.residuals.number):
        out.append(FigureFile(
            "residuals.png", "Residuals",
            f"Residual of every reading in the order taken, coloured by leg; rms "
            f"{um(fit.residual_rms_mm)} against a gauge noise band of ±2σ.",
            png_bytes(residuals_figure(data.residuals, fit.noise_mm, fit.residual_rms_mm))))
    if fit is not None:
        validation = data.validation.fit if data.validation else None
        out.append(FigureFile(
            "parameters.png", "Identified parameters",
            "Identified joint offsets with their expanded uncertainty U (k = 2) as "
            "whiskers, and U itself.",
            png_bytes(parameters_figure(
                fit, validation, _expanded(typed.result_entries, fit),
                _expanded(typed.validation_result_entries, validation)))))
    if data.diagnosis is not None and len(data.diagnosis_steps) > 1:
        out.append(FigureFile(
            "diagnosis.png", "Residuals before and after each effect",
            "Residuals with the joint offsets only and with each effect of the diagnosis "
            "added, on one scale.",
            png_bytes(diagnosis_figure(data.diagnosis_steps, data.diagnosis.noise_mm))))
    if data.diagnosis is not None and data.diagnosis.profiles:
        out.append(FigureFile(
            "profiles.png", "Residuals along each scanned leg",
            "Each gauge's mean residual at each position along its leg's joint coordinate, "
            "with the joint offsets only and with the effects found, against the gauge "
            "noise band.",
            png_bytes(profiles_figure(data.diagnosis.profiles, data.diagnosis.noise_mm))))
    if data.diagnosis is not None and data.diagnosis.maps:
        out.append(FigureFile(
            "maps.png", "Error map of each actuator",
            "Actual minus commanded joint position along each actuator with an error map, "
            "forward and reverse, with a band of two standard uncertainties.",
            png_bytes(maps_figure(data.diagnosis.maps))))
    if typed.history:
        calibrations = recorded_calibrations(typed)
        if any(c.parameters for c in calibrations):
            out.append(FigureFile(
                "history.png", "History of this machine's calibrations",
                "Each parameter at each calibration of this machine, with its expanded "
                "uncertainty as error bars, this calibration marked.",
                png_bytes(history_figure("This machine's calibrations over time",
                                         calibrations, current=str(typed.id)))))
    return tuple(out)


def _expanded(results: Sequence[NamedResult], fit: FitSummary | None,
              ) -> dict[str, float | None]:
    """U of each parameter of ``fit``, from the record's ``results``."""
    found = by_name(results)
    return {p.name: found[p.name].U_mm if p.name in found else None
            for p in fit.parameters} if fit is not None else {}


def build_report(data: ReportData, record: Mapping[str, Any]) -> Report:
    """The page of ``record`` (built from the same session as ``data``)."""
    figures = figures_for(data, record)
    return Report(data, record, figures, render_page(data, figures, record))


def write_report(report: Report, folder: str | Path) -> Path:
    """Write ``report.html``, ``record.json`` and the PNG figures into ``folder``;
    returns the HTML path.
    Each file is replaced whole (a full disk leaves no truncated figure), the page
    last, so a page on disk never names figures that are not; StorageError when
    the folder cannot be written, the files this call made then removed again (a
    file it replaced stays replaced: whole, and the retry replaces it again)."""
    folder = Path(folder)
    made_folder = not folder.exists()
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise StorageError(folder, exc, "create the report folder") from None
    path = folder / REPORT_NAME
    files = [(folder / f.name, f.png) for f in report.figures]
    files += [(folder / RECORD_NAME, report.record_json().encode("utf-8")),
              (path, report.html.encode("utf-8"))]
    made: list[Path] = []
    try:
        for target, data in files:
            new = not target.exists()
            write_atomically(target, data)
            if new:
                made.append(target)
    except StorageError:
        for target in made:
            with contextlib.suppress(OSError):
                target.unlink()
        if made_folder:
            with contextlib.suppress(OSError):
                folder.rmdir()
        raise
    return path


__all__ = ["RECORD_NAME", "REPORT_NAME", "DiagnosisFormatError", "DiagnosisView", "Report",
           "ReportData", "build_report", "collect", "parse_diagnosis", "write_report"]
