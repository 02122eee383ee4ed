"""The report as one self-contained HTML page: inline style, figures as data: URIs,
no script and no external asset.

The markup is the jinja2 template ``templates/report.html.j2``, whose environment
escapes every value it prints (autoescape): text from a session cannot become
markup. This module chooses the words and numbers: sentences, badges and tables
of plain strings.
"""

from __future__ import annotations

import base64
from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import Any, NamedTuple

import jinja2

from ogacq.identify.consistency import format_p
from ogacq.model.units import UM_PER_MM
from ogacq.record.calibration_record import CalibrationRecord
from ogacq.record.declared import written
from ogacq.record.sections import ResultEntry
from ogacq.report.cells import Badge, Cell, Fallback, Lines, Table, kinds, spaced
from ogacq.report.cells import table as _table
from ogacq.report.data import FitSummary, ParameterRow, ReportData, status_notes
from ogacq.report.diagnosis_view import DiagnosisView, EffectFound
from ogacq.report.figures import FigureFile
from ogacq.report.formatting import (
    duration,
    finite,
    measure,
    plain,
    signed,
    um,
)
from ogacq.report.record_view import (
    by_name,
    css_string,
    entry_headline,
    record_view,
    revision_label,
    shown,
)
from ogacq.session.state import CampaignStatus
from ogacq.uncertainty.reporting import two_digits

_TEMPLATES = jinja2.Environment(loader=jinja2.PackageLoader("ogacq.report", "templates"),
                                autoescape=True, undefined=jinja2.StrictUndefined,
                                keep_trailing_newline=True)


class Figure(NamedTuple):
    png_base64: str
    description: str
    name: str


# --- sentences ----------------------------------------------------------------------------

def recorded_status(record: CalibrationRecord, faults: tuple[str, ...] = ()) -> CampaignStatus:
    """The campaign's status as the record states it (``campaign``: status, readings,
    planned, reason), with the faults the session lists (the record has none)."""
    campaign = record.campaign_section
    return CampaignStatus(campaign.status or "incomplete", campaign.readings or 0,
                          campaign.planned, campaign.reason, faults, ())


def status_badge(status: CampaignStatus) -> Badge:
    if status.complete:
        return Badge("campaign complete", "ok")
    return Badge(f"campaign {status.status}", "bad" if status.status == "stopped" else "warn")


def session_notes(record: CalibrationRecord) -> list[str]:
    """What the record says about its session before anything else: partial (the
    campaign did not finish), edited (accepted as it stands), an older format."""
    from ogacq.session.seal import Integrity

    session = record.session_file
    edited = tuple((e.line or 0, str(e.problem)) for e in session.edited)
    partial = record.campaign_section.partial
    notes = [partial] if partial else []
    return notes + Integrity(session.integrity or "sealed", edited).notes()


def recorded_verdict(record: CalibrationRecord) -> tuple[str, str]:
    """The record's verdict (``verdict``: the one consistency test's, as every command
    states it): its state and its sentence; undetermined without one."""
    verdict = record.verdict_section
    if verdict is None:
        return "undetermined", ""
    return verdict.state or "undetermined", verdict.text or ""


VERDICT_KIND = kinds({"consistent": "ok", "inconsistent": "bad"})  # a verdict's state's badge


def misfit_sentence(verdict: tuple[str, str]) -> tuple[str, str]:
    """(badge kind, sentence): the record's verdict (``recorded_verdict``) and what it
    means for the offsets."""
    state, text = verdict
    kind = VERDICT_KIND[state]
    meaning = {"ok": "the joint offsets explain the readings.",
               "bad": "the model leaves something out, so the offsets alone will not make "
                      "the machine accurate (see the diagnosis).",
               "info": "nothing can be concluded from these readings."}[kind]
    return kind, f"{text}: {meaning}"


def _fit_badge(kind: str) -> Badge:
    text = {"ok": "within noise", "bad": "not within noise", "info": "cannot be judged"}
    return Badge(text[kind], kind)


def diagnosis_sentence(d: DiagnosisView) -> tuple[str, str]:
    outcome = d.outcome
    if outcome == "consistent":
        return "ok", "consistent: the joint-offset model reproduces the readings within the noise"
    names = ", ".join(e.name for e in d.named_effects)
    if outcome == "undetermined":
        return "info", "undetermined: these readings leave nothing to judge the fit by"
    if outcome == "explained":
        return "warn", f"explained by {names}: with it the fit is within the gauge noise"
    if outcome == "partly explained":
        return "bad", (f"partly explained by {names}; the rest sits at "
                       f"{d.unexplained_where or '?'} and no known effect explains it")
    return "bad", (f"unexplained: no known effect brings the fit within the noise; the misfit "
                   f"sits at {d.unexplained_where or '?'}")


def _offsets_inline(fit: FitSummary, results: Mapping[str, ResultEntry],
                    ) -> list[tuple[str, str]]:
    """``x +0.0347 ± 0.0035 mm (k = 2)``: each offset's headline, its U the record's."""
    return [(p.name.split(".")[-1], _headline(p, results)) for p in fit.parameters]


def _headline(p: ParameterRow, results: Mapping[str, ResultEntry]) -> str:
    """The parameter's value as identified, its U the record's."""
    if not finite(p.std):
        return "not determined"
    recorded = results[p.name] if p.name in results else ResultEntry()
    return str(entry_headline(replace(recorded, value_mm=p.value), p.unit))


MACHINE_WORDS = Fallback({"leg_length_mm": ("leg length", "mm"),
                          "rho_min_mm": ("Min posture", "mm"), "rho_max_mm": ("Max posture", "mm"),
                          "gauge_resolution_mm": ("gauge resolution", "mm"),
                          "gauge_repeatability_mm": ("gauge repeatability", "mm"),
                          "leg_expansion_ppm_per_k": ("legs' expansion", "ppm/K")},
                         lambda key: (spaced(key), ""))


def machine_words(machine: dict) -> str:
    """``leg length 310.25 mm, Min posture -100.0 mm, ...``; unknown keys as they are."""
    parts = []
    for key, value in machine.items():
        words, unit = MACHINE_WORDS[key]
        if isinstance(value, dict):  # a table of the machine file ([tolerances])
            parts.append(f"{words} ({shown(value)})")
        else:
            parts.append(f"{words} {value}{' ' + unit if unit else ''}")
    return ", ".join(parts) or "not recorded"


# --- tables -------------------------------------------------------------------------------

def _deviations(data: ReportData) -> tuple[Table | None, str]:
    """The table of deviations, and what the figure's bottom row shows."""
    if not data.deviations:
        return None, ""
    validated = any(r.after_measured_mm is not None for r in data.deviations)
    header = ["deviation", "leg", "gauge along", "posture", "before (mm)",
              "after, predicted (µm)"]
    header += ["after, measured (µm)"] if validated else []
    header += ["noise ±2σ (µm)"]
    rows: list[list[Cell]] = []
    for r in data.deviations:
        row: list[Cell] = [r.name, r.leg, r.gauge_axis, r.posture.capitalize(),
                           signed(r.before_mm), signed(r.after_predicted_mm * UM_PER_MM, 2)]
        if validated:
            row.append(signed(None if r.after_measured_mm is None
                              else r.after_measured_mm * UM_PER_MM, 2))
        row.append(plain(2 * r.noise_mm * UM_PER_MM, 2))
        rows.append(row)
    after = ("the bottom row shows what remains once the identified offsets are compensated, "
             "predicted from this session" + (" and measured by the validation campaign"
                                               if validated else ""))
    return _table(header, rows, [False] * 4 + [True] * (len(header) - 4)), after


def _parameters(fit: FitSummary, validation: FitSummary | None,
                record: CalibrationRecord) -> Table:
    """Each parameter's headline (value ± U, k = 2), the fit's std as its detail."""
    header = ["parameter", "value ± U", "fit std (detail)"]
    header += ["remaining after write-back (validation)"] if validation else []
    rows: list[list[Cell]] = []
    for p in fit.parameters:
        row: list[Cell] = [p.name, _headline(p, by_name(record.result_entries)),
                           f"{two_digits(p.std)} {p.unit}" if finite(p.std) else "-"]
        if validation is not None:
            other = validation.row(p.name)
            row.append(_headline(other, by_name(record.validation_result_entries))
                       if other else "-")
        rows.append(row)
    return _table(header, rows, [False, True, True] + ([True] if validation else []))


def _residuals(fit: FitSummary) -> Table:
    noise_dof = f", {fit.noise_dof} dof" if fit.noise_dof else ""
    return _table(None, [
        ["residual rms", um(fit.residual_rms_mm)],
        ["noise implied by the residuals, √(RSS/dof)", f"{um(fit.sigma_mm)} ({fit.dof} dof)"],
        ["gauge noise σ", f"{um(fit.noise_mm)} ({fit.noise_source}{noise_dof})"],
        ["ratio", f"×{fit.misfit_ratio:.2f}" if finite(fit.misfit_ratio) else "-"]],
        [False, True])


def _identifiability(fit: FitSummary) -> Table:
    return _table(None, [
        ["rank of the design", f"{fit.rank} of {len(fit.parameters)}"],
        ["condition number (columns scaled to plausible ranges)",
         f"{fit.condition_number:.4g}" if finite(fit.condition_number) else "infinite"],
        ["correlated pairs (|r| > 0.95)", ", ".join(
            f"{a} / {b} {c:+.4f}" for a, b, c in fit.correlated_pairs) or "none"]],
        [False, True])


def _effect_row(e: EffectFound) -> list[Cell]:
    value = ("-" if e.value is None else measure(e.value, e.std, e.unit or "-"))
    if e.alternatives:
        alternatives = ("explained equally well by " + ", ".join(e.alternative_names)
                        + ": not separable with this campaign")
    elif e.unexplained:
        alternatives = "no known effect explains this part of the misfit: look at that gauge"
    else:
        alternatives = "none: no other known effect explains the data as well"
    separation: Cell = Lines(tuple(e.separated_by)) if e.separated_by else "-"
    if e.alternatives and not e.separated_by:
        separation = ("run `ogacq diagnose` on this session: it names the extra postures "
                      "or cycles that would tell these apart")
    name: Cell = f"unexplained misfit at {e.where}" if e.unexplained else e.name
    if e.located:  # an error map: where along which axis, its shape
        name = Lines((e.name, e.located))
    return [name, value, alternatives, separation]


def _diagnosis(d: DiagnosisView, fit: FitSummary | None) -> dict[str, Any]:
    kind, sentence = diagnosis_sentence(d)
    models = [("joint offsets only", d.base)]
    if not d.base.consistent:
        models.append(("with the effects found", d.final))
    out: dict[str, Any] = {
        "diagnosis_badge": Badge(d.outcome, kind), "diagnosis_sentence": sentence,
        "diagnosis_offsets": [(a, f"{signed(v, 5)} mm") for a, v in sorted(d.offsets_mm.items())],
        "models": _table(["model", "residual rms", "χ²/dof", "verdict"], [
            [title, um(v.rms_mm), plain(v.chi2_dof, 2),
             _fit_badge("ok" if v.consistent else "bad")]
            for title, v in models], [False, True, True, False]),
        "located": None, "effects": None, "offsets_compared": None}
    if d.located and not d.base.consistent:
        out["located"] = _table(["gauge", "leg", "along", "share of the misfit"], [
            [g.gauge, str(g.leg), str(g.gauge_axis), f"{g.share:.0%}"] for g in d.located],
            [False, False, False, True])
    if d.effects:
        ambiguous = any(e.alternatives for e in d.effects)
        header = ["effect", "value ± std", "alternatives"]
        header += ["what would separate them"] if ambiguous else []
        out["effects"] = _table(header, [_effect_row(e)[:len(header)] for e in d.effects],
                                [False, True, False, False][:len(header)])
    out |= _along_axes(d)
    if d.offsets_mm and d.named_effects:
        # an axis the fit did not identify: None, "-"
        base = dict.fromkeys(d.offsets_mm) | ({p.name.split(".")[-1]: p.value
                                               for p in fit.parameters} if fit else {})
        out["offsets_compared"] = _table(["axis", "offsets only", "with the effects"], [
            [a, signed(base[a], 5), signed(v, 5)] for a, v in sorted(d.offsets_mm.items())],
            [False, True, True])
    return out


def _along_axes(d: DiagnosisView) -> dict[str, Any]:
    """The map search's account: how each axis was read, the chi-square and p before
    and after, the scans that would separate what the readings cannot."""
    names = {"base": "joint offsets only", "library": "with the library's effects",
             "final": "with the maps too (final)"}
    rows: list[list[Cell]] = []
    for key, title in names.items():
        if key not in d.chi2:
            continue
        v = d.chi2[key]
        # the p as the verdict's text says it (4.6e-13 there, 4.58e-13 here before)
        rows.append([title, plain(v.statistic, 1), str(v.dof or 0), format_p(v.p),
                     _fit_badge("ok" if v.consistent else "bad")])
    return {"axes_coverage": list(d.coverage), "proposals": list(d.proposals),
            "map_chi2": _table(["model", "χ²", "dof", "p", "verdict"], rows,
                               [False, True, True, True, False]) if rows else None}


def _provenance(data: ReportData) -> Table:
    p = data.provenance
    simulated = ("yes: " + ", ".join(f"{k} {v}" for k, v in (p.simulator or {}).items()
                                     if v not in ("", None)) if p.simulated else "no")
    rows: list[list[Cell]] = [
        ["session file", p.session_path], ["recorded by", p.software], ["started", p.created],
        ["campaign length (station clock)", duration(p.campaign_time_s)],
        ["machine", machine_words(p.machine)], ["machine file", p.machine_file or "-"],
        ["campaign file", p.campaign_file or "-"], ["simulated machine", simulated]]
    if p.plan is not None and written(p.plan):
        plan = p.plan
        rows.append(["plan", f"legs {', '.join(plan.legs)}; postures "
                             f"{' → '.join(plan.postures)}; "
                             f"{'?' if plan.cycles is None else plan.cycles} cycles; approach "
                             f"{plan.approach or '?'}"])
    rows += [[what, desc] for what, desc in (*p.station, *p.other)]
    rows += [["resumed", r] for r in p.resumes]
    rows += [["fault", f] for f in data.faults]
    if data.validation is not None:
        v = data.validation.provenance
        rows.append(["validation session", f"{v.session_path} ({v.software}, started "
                                           f"{v.created}, {data.validation.status.readings} "
                                           f"readings, {data.validation.status.status})"])
        if data.validation.note:
            rows.append(["validation note", data.validation.note])
    rows.append(["report made by", f"{p.report_software} at {p.reported}"])
    return _table(None, rows)


# --- the page -----------------------------------------------------------------------------

def render_page(data: ReportData, figures: Sequence[FigureFile],
                record: Mapping[str, Any]) -> str:
    """The page: the calibration record's sections (``record``, the ``ogacq-record/1``
    document of the same campaign) then the analysis behind them (``data``)."""
    p = data.provenance
    fit = data.fit
    typed = CalibrationRecord.from_json(record)
    machine = typed.machine_section.name or p.machine_name or p.machine_file or "machine"
    validation_fit = data.validation.fit if data.validation is not None else None
    deviations, deviations_after = _deviations(data)
    status = recorded_status(typed, data.faults)
    context: dict[str, Any] = record_view(typed) | {
        "page_issued": css_string(str(typed.issued)),
        "data": data, "p": p, "fit": fit, "d": data.diagnosis, "machine": machine,
        "title": f"Calibration record {revision_label(typed)}: {machine}"
                 + (" (SIMULATED)" if p.simulated else ""),
        "status": status, "status_badge": status_badge(status), "um": um,
        "notes": status_notes(status) + list(data.notes),
        "session_notes": session_notes(typed),
        "figures": Fallback[Figure | None]({f.name.removesuffix(".png"): Figure(
            base64.b64encode(f.png).decode("ascii"), f.description, f.name) for f in figures},
            lambda _: None),
        "deviations": deviations, "deviations_after": deviations_after,
        "validation_fit": validation_fit,
        "provenance": _provenance(data)}
    if fit is not None:
        kind, sentence = misfit_sentence(recorded_verdict(typed))
        context |= {"offsets": _offsets_inline(fit, by_name(typed.result_entries)),
                    "fit_badge": _fit_badge(kind),
                    "fit_sentence": sentence,
                    "glance_condition": f"{fit.condition_number:.3g}",
                    "parameters": _parameters(fit, validation_fit, typed),
                    "residuals": _residuals(fit), "identifiability": _identifiability(fit)}
    if validation_fit is not None:
        context["validation_offsets"] = _offsets_inline(
            validation_fit, by_name(typed.validation_result_entries))
    if data.diagnosis is not None:
        context |= _diagnosis(data.diagnosis, fit)
    return _TEMPLATES.get_template("report.html.j2").render(context)
