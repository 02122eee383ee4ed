"""The report as one self-contained HTML page: inline style, figures as data: URIs,
no script and no external asset, every text from the session escaped."""

from __future__ import annotations

import base64
import html
from collections.abc import Iterable, Sequence

from ogacq.report.data import CampaignStatus, FitSummary, ReportData
from ogacq.report.diagnosis_view import DiagnosisView, EffectFound
from ogacq.report.figures import FigureFile
from ogacq.report.formatting import duration, finite, measure, plain, signed, um

STYLE = """
body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,"DejaVu Sans",sans-serif;
 margin:0;background:#f4f5f7;color:#1d2329;line-height:1.45}
main{max-width:1120px;margin:0 auto;padding:24px 28px 48px;background:#fff}
h1{margin:0 0 4px;font-size:1.7em}h2{margin-top:2.2em;border-bottom:2px solid #dde1e6;
 padding-bottom:4px;font-size:1.3em}h3{font-size:1.05em;margin:1.4em 0 .4em}
.sub{color:#5b6670;margin:0 0 18px}
table{border-collapse:collapse;margin:10px 0 14px;font-size:.93em}
th,td{border:1px solid #d5dae0;padding:4px 9px;text-align:left;vertical-align:top}
th{background:#eef1f4;font-weight:600}td.num{text-align:right;
 font-variant-numeric:tabular-nums;white-space:nowrap}
.glance{display:grid;grid-template-columns:max-content 1fr;gap:6px 18px;
 border:1px solid #d5dae0;border-radius:6px;padding:14px 18px;background:#fafbfc}
.glance dt{font-weight:600;color:#3c4650}.glance dd{margin:0}
.badge{display:inline-block;padding:1px 9px;border-radius:10px;font-size:.85em;
 font-weight:600;color:#fff;vertical-align:middle}
.ok{background:#2e7d32}.warn{background:#b26a00}.bad{background:#c62828}
.info{background:#546e7a}
.notes{border-left:5px solid #b26a00;background:#fff8e6;padding:10px 16px;margin:16px 0}
.notes p{margin:.3em 0}
figure{margin:12px 0 6px}figure img{max-width:100%;height:auto;border:1px solid #e3e6ea}
figcaption{color:#4d5862;font-size:.92em;margin-top:4px}
.muted{color:#6b7680}code{background:#f0f2f4;padding:0 3px;border-radius:3px}
footer{margin-top:3em;color:#6b7680;font-size:.85em}
"""


def esc(value: object) -> str:
    return html.escape(str(value), quote=True)


def _badge(text: str, kind: str) -> str:
    return f'<span class="badge {kind}">{esc(text)}</span>'


def _table(header: Sequence[str] | None, rows: Iterable[Sequence[str]],
           numeric: Sequence[bool] | None = None) -> str:
    """A table from pre-escaped cells; without a header, the first column names the rows."""
    rows = list(rows)
    width = len(header) if header else max((len(r) for r in rows), default=0)
    numeric = numeric or [False] * width
    head = ("<thead><tr>" + "".join(f"<th>{esc(h)}</th>" for h in header) + "</tr></thead>"
            if header else "")

    def cell(k: int, c: str) -> str:
        if not header and k == 0:
            return f'<th scope="row">{c}</th>'
        return f'<td class="num">{c}</td>' if numeric[k] else f"<td>{c}</td>"

    body = "".join("<tr>" + "".join(cell(k, c) for k, c in enumerate(row)) + "</tr>"
                   for row in rows)
    return f"<table>{head}<tbody>{body}</tbody></table>"


def _figure(fig: FigureFile | None, caption: str) -> str:
    if fig is None:
        return ""
    data = base64.b64encode(fig.png).decode("ascii")
    return (f'<figure><img src="data:image/png;base64,{data}" alt="{esc(fig.description)}">'
            f"<figcaption>{caption} <span class=\"muted\">({esc(fig.name)})</span>"
            "</figcaption></figure>")


# --- sentences ----------------------------------------------------------------------------

def status_badge(status: CampaignStatus) -> str:
    if status.complete:
        return _badge("campaign complete", "ok")
    return _badge(f"campaign {status.status}", "bad" if status.status == "stopped" else "warn")


def misfit_sentence(fit: FitSummary) -> tuple[str, str]:
    """(badge kind, sentence): the consistency test's verdict, as every command states
    it, and what it means for the offsets."""
    kind = {"consistent": "ok", "inconsistent": "bad"}.get(fit.verdict, "info")
    meaning = {"ok": "the joint offsets explain the readings.",
               "bad": "the model leaves something out, so the offsets alone will not make "
                      "the machine accurate (see the diagnosis).",
               "info": "nothing can be concluded from these readings."}[kind]
    return kind, f"{fit.verdict_text}: {meaning}"


def _fit_badge(kind: str) -> str:
    text = {"ok": "within noise", "bad": "not within noise", "info": "cannot be judged"}
    return _badge(text[kind], kind)


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


# --- sections -----------------------------------------------------------------------------

def _offsets_inline(fit: FitSummary) -> str:
    return "; ".join(f"{esc(p.name.split('.')[-1])} <b>{esc(measure(p.value, p.std, p.unit))}</b>"
                     for p in fit.parameters)


def _glance(data: ReportData) -> str:
    s = data.status
    planned = f" of {s.planned} planned" if s.planned else ""
    items = [("Campaign", f"{status_badge(s)} {s.readings} readings{esc(planned)}")]
    if data.fit is not None:
        kind, sentence = misfit_sentence(data.fit)
        items.append(("Joint offsets", _offsets_inline(data.fit) + " (joint-offset model)"))
        items.append(("Fit", f"{_fit_badge(kind)} {esc(sentence)}"))
        ident = data.fit
        items.append(("Identifiable", _badge("yes", "ok") + f" condition number "
                      f"{ident.condition_number:.3g}" if ident.identifiable else
                      _badge("no", "bad") + " " + esc("; ".join(ident.reasons))))
    else:
        items.append(("Joint offsets", _badge("not identified", "bad")))
    if data.diagnosis is not None:
        kind, sentence = diagnosis_sentence(data.diagnosis)
        items.append(("Diagnosis", f"{_badge(data.diagnosis.outcome, kind)} {esc(sentence)}"))
        if data.diagnosis.named_effects and data.diagnosis.offsets_mm:
            offsets = "; ".join(f"{esc(a)} <b>{esc(signed(v, 5))} mm</b>"
                                for a, v in sorted(data.diagnosis.offsets_mm.items()))
            items.append(("Offsets with the effects", f"{offsets} (the offsets-only fit above "
                          "absorbs part of the effects; see Diagnosis)"))
    elif data.diagnosis_note:
        items.append(("Diagnosis", esc(data.diagnosis_note)))
    if data.validation is not None and data.validation.fit is not None:
        v = data.validation.fit
        items.append(("After write-back", "validation campaign: remaining offsets "
                      + _offsets_inline(v) + f", residual rms {esc(um(v.residual_rms_mm))}"))
    if data.writes:
        last = data.writes[-1]
        items.append(("Written to controller", f"{esc(last.action)} {esc(last.status)} "
                      f"{esc(last.when)}" + (f" ({len(data.writes)} operations)"
                                              if len(data.writes) > 1 else "")
                      + ", see Identified parameters"))
    body = "".join(f"<dt>{esc(k)}</dt><dd>{v}</dd>" for k, v in items)
    return f'<dl class="glance">{body}</dl>'


def _notes(data: ReportData) -> str:
    if not data.notes:
        return ""
    return '<div class="notes">' + "".join(f"<p>{esc(n)}</p>" for n in data.notes) + "</div>"


def _deviations(data: ReportData, figures: dict[str, FigureFile]) -> str:
    if not data.deviations:
        return ("<h2 id=\"deviations\">Deviations per leg and posture</h2><p>No leg was read "
                "at Zero and at Max or Min: there are no deviations to show.</p>")
    validated = any(r.after_measured_mm is not None for r in data.deviations)
    header = ["deviation", "leg", "gauge along", "posture", "before (mm)",
              "after, predicted (µm)"]
    header += ["after, measured (µm)"] if validated else []
    header += ["noise ±2σ (µm)"]
    rows = []
    for r in data.deviations:
        row = [esc(r.name), esc(r.leg), esc(r.gauge_axis), esc(r.posture.capitalize()),
               esc(signed(r.before_mm)), esc(signed(r.after_predicted_mm * 1e3, 2))]
        if validated:
            row.append(esc(signed(None if r.after_measured_mm is None
                                  else r.after_measured_mm * 1e3, 2)))
        row.append(esc(plain(2 * r.noise_mm * 1e3, 2)))
        rows.append(row)
    numeric = [False] * 4 + [True] * (len(header) - 4)
    after = ("the bottom row shows what remains once the identified offsets are compensated, "
             "predicted from this session" + (" and measured by the validation campaign"
                                               if validated else ""))
    return ('<h2 id="deviations">Deviations per leg and posture</h2>'
            "<p>Each gauge's reading at Max and at Min minus its reading at Zero, averaged "
            "over the cycles: <code>dy_x+</code> is along y on the x leg at Max. A perfectly "
            "calibrated machine reads zero everywhere.</p>"
            + _figure(figures.get("deviations"), f"Top row: measured before calibration (mm); "
                      f"{after} (µm), against the gauge-noise band ±2σ.")
            + _table(header, rows, numeric))


def _parameters(data: ReportData, figures: dict[str, FigureFile]) -> str:
    fit = data.fit
    out = ['<h2 id="parameters">Identified parameters</h2>']
    if fit is None:
        return out[0] + "<p>Nothing was identified (see the notes above).</p>"
    out.append(f"<p>Exact nonlinear fit of the joint offsets to all {fit.n_readings} readings "
               "(each gauge's own zero fitted alongside). The std is propagated from the gauge "
               f"noise σ = {esc(um(fit.noise_mm))} ({esc(fit.noise_source)}); the 95 % "
               "interval is ±1.96 std.</p>")
    out.append(_figure(figures.get("parameters"), "Identified values with their 95 % "
                       "confidence intervals, and the width of those intervals."))
    v = data.validation.fit if data.validation else None
    header = ["parameter", "value", "std", "95 % interval", "unit"]
    header += ["remaining after write-back (validation)"] if v else []
    rows = []
    for p in fit.parameters:
        interval = (f"{p.value - p.ci95_half:+.5f} … {p.value + p.ci95_half:+.5f}"
                    if finite(p.std) else "not determined")
        value = signed(p.value, 5) if finite(p.std) else "not determined"
        row = [esc(p.name), esc(value), esc(plain(p.std, 5)), esc(interval), esc(p.unit)]
        if v is not None:
            other = v.row(p.name)
            row.append(esc(measure(other.value, other.std, other.unit) if other else "-"))
        rows.append(row)
    out.append(_table(header, rows, [False, True, True, True, False] + ([True] if v else [])))
    out.append(f"<p>In one line: {_offsets_inline(fit)}.</p>")
    if data.writes:
        out.append("<h3>Written to the controller</h3>")
        for w in data.writes:
            kind = {"done": "ok", "failed": "bad"}.get(w.status, "warn")
            rows = [[esc(a), esc(signed(w.old_mm.get(a), 5)), esc(signed(w.new_mm.get(a), 5))]
                    for a in sorted({*w.old_mm, *w.new_mm})]
            out.append(f"<p>{_badge(f'{w.action} {w.status}', kind)} {esc(w.when)}: "
                       f"{esc(w.details)}</p>"
                       + _table(["joint offset", "before (mm)", "after (mm)"], rows,
                                [False, True, True]))
    return "".join(out)


def _residuals(data: ReportData, figures: dict[str, FigureFile]) -> str:
    fit = data.fit
    if fit is None or data.residuals is None:
        return ""
    kind, sentence = misfit_sentence(fit)
    noise_dof = f", {fit.noise_dof} dof" if fit.noise_dof else ""
    rows = [["residual rms", esc(um(fit.residual_rms_mm))],
            ["noise implied by the residuals, √(RSS/dof)", esc(f"{um(fit.sigma_mm)} "
                                                                f"({fit.dof} dof)")],
            ["gauge noise σ", esc(f"{um(fit.noise_mm)} ({fit.noise_source}{noise_dof})")],
            ["ratio", esc(f"×{fit.misfit_ratio:.2f}" if finite(fit.misfit_ratio) else "-")]]
    return ('<h2 id="residuals">Residuals</h2>'
            f"<p>{_fit_badge(kind)} {esc(sentence)}</p>"
            + _figure(figures.get("residuals"), "Each reading minus what the identified model "
                      "predicts (gauge zeros removed), in the order taken, coloured by leg. "
                      "Under noise alone about 95 % of the points fall inside the grey band; "
                      "a pattern by leg, posture or time means something is left out.")
            + _table(None, rows, [False, True]))


def _identifiability(data: ReportData) -> str:
    fit = data.fit
    if fit is None:
        return ""
    n = len(fit.parameters)
    verdict = (_badge("identifiable", "ok") + " every parameter is determined by these data"
               if fit.identifiable else _badge("not identifiable", "bad")
               + " these data do not determine every parameter")
    rows = [["rank of the design", esc(f"{fit.rank} of {n}")],
            ["condition number (columns scaled to plausible ranges)",
             esc(f"{fit.condition_number:.4g}" if finite(fit.condition_number) else "infinite")],
            ["correlated pairs (|r| > 0.95)", esc(", ".join(
                f"{a} / {b} {c:+.4f}" for a, b, c in fit.correlated_pairs) or "none")]]
    reasons = "".join(f"<li>{esc(r)}</li>" for r in fit.reasons)
    return ('<h2 id="identifiability">Identifiability</h2>'
            f"<p>{verdict}.</p>" + _table(None, rows, [False, True])
            + (f"<ul>{reasons}</ul>" if reasons else "")
            + "<p class=\"muted\">A condition number near 1 means the postures see each "
              "offset independently; correlated pairs are fixed only in combination.</p>")


def _effect_row(e: EffectFound) -> list[str]:
    value = ("-" if e.value is None else measure(e.value, e.std, e.unit))
    if e.alternatives:
        alternatives = ("explained equally well by " + ", ".join(e.alternatives)
                        + ": not separable with this campaign")
    elif e.unexplained:
        alternatives = "no known effect explains this part of the misfit: look at that gauge"
    else:
        alternatives = "none: no other known effect explains the data as well"
    separation = "<br>".join(esc(s) for s in e.separated_by)
    if e.alternatives and not separation:
        separation = esc("run `ogacq diagnose` on this session: it names the extra postures "
                         "or cycles that would tell these apart")
    name = f"unexplained misfit at {e.where}" if e.unexplained else e.name
    return [esc(name), esc(value), esc(alternatives), separation or "-"]


def _diagnosis(data: ReportData, figures: dict[str, FigureFile]) -> str:
    out = ['<h2 id="diagnosis">Diagnosis</h2>']
    d = data.diagnosis
    if d is None:
        note = esc(data.diagnosis_note or "no diagnosis was given") + "."
        if data.fit is not None:
            p = data.provenance
            machine = p.machine_file or "M.toml"
            note += (f" <code>ogacq diagnose {esc(p.session_path)} --machine {esc(machine)} "
                     f"--json &gt; diagnosis.json</code> then <code>ogacq report "
                     f"{esc(p.session_path)} --diagnosis diagnosis.json</code> adds it here.")
        out.append(f'<p class="muted">{note}</p>')
        return "".join(out)
    kind, sentence = diagnosis_sentence(d)
    out.append(f"<p>{_badge(d.outcome, kind)} {esc(sentence)}.</p>")
    models = [("joint offsets only", d.base)]
    if not d.base.consistent:
        models.append(("with the effects found", d.final))
    rows = [[esc(title), esc(um(v.rms_mm)), esc(plain(v.chi2_dof, 2)),
             _badge("within noise", "ok") if v.consistent else _badge("not within noise", "bad")]
            for title, v in models]
    out.append(f"<p>Judged against the gauge noise σ = {esc(um(d.noise_mm))}.</p>"
               + _table(["model", "residual rms", "χ²/dof", "verdict"], rows,
                        [False, True, True, False]))
    if d.located and not d.base.consistent:
        located = [[esc(g.gauge), esc(g.leg), esc(g.gauge_axis), esc(f"{g.share:.0%}")]
                   for g in d.located]
        out.append("<h3>Where the misfit of the joint-offset model sits</h3>"
                   + _table(["gauge", "leg", "along", "share of the misfit"], located,
                            [False, False, False, True]))
    if d.effects:
        ambiguous = any(e.alternatives for e in d.effects)
        header = ["effect", "value ± std", "alternatives"]
        header += ["what would separate them"] if ambiguous else []
        out.append("<h3>Effects, most important first</h3>" + _table(
            header, [_effect_row(e)[:len(header)] for e in d.effects],
            [False, True, False, False][:len(header)]))
    if d.offsets_mm and d.named_effects:
        base = {p.name.split(".")[-1]: p.value for p in data.fit.parameters} if data.fit else {}
        rows = [[esc(a), esc(signed(base.get(a), 5)), esc(signed(v, 5))]
                for a, v in sorted(d.offsets_mm.items())]
        out.append("<h3>Joint offsets (mm): offsets-only model and the diagnosis's final "
                   "model</h3>" + _table(["axis", "offsets only", "with the effects"], rows,
                                         [False, True, True])
                   + "<p class=\"muted\">The offsets-only fit absorbs part of an effect it "
                   "does not model: the final model's offsets are the ones that belong with "
                   "the effects found.</p>")
    if data.diagnosis_steps and len(data.diagnosis_steps) > 1:
        out.append(_figure(figures.get("diagnosis"), "Residuals with the joint offsets only, "
                           "then with each effect added (refitted here from the readings), "
                           "on one scale, against the gauge-noise band."))
    if data.diagnosis_note:
        out.append(f"<p class=\"muted\">{esc(data.diagnosis_note)}</p>")
    if d.outcome != "consistent":  # as `ogacq diagnose` does: caveats qualify a finding
        out += [f'<div class="notes"><p>{esc(c)}</p></div>' for c in d.caveats]
    return "".join(out)


def _provenance(data: ReportData) -> str:
    p = data.provenance
    machine = machine_words(p.machine)
    rows = [["session file", esc(p.session_path)],
            ["recorded by", esc(p.software)], ["started", esc(p.created)],
            ["campaign length (station clock)", esc(duration(p.campaign_time_s))],
            ["machine", esc(machine)],
            ["machine file", esc(p.machine_file or "-")],
            ["campaign file", esc(p.campaign_file or "-")],
            ["simulated machine", esc("yes: " + ", ".join(f"{k} {v}" for k, v in
                                                           (p.simulator or {}).items()
                                                           if v not in ("", None))
                                      if p.simulated else "no")]]
    if p.plan:
        plan = p.plan
        rows.append(["plan", esc(f"legs {', '.join(map(str, plan.get('legs', [])))}; postures "
                                 f"{' → '.join(map(str, plan.get('postures', [])))}; "
                                 f"{plan.get('cycles', '?')} cycles; approach "
                                 f"{plan.get('approach', '?')}")])
    rows += [[esc(what), esc(desc)] for what, desc in p.station]
    rows += [[esc(what), esc(desc)] for what, desc in p.other]
    rows += [["resumed", esc(r)] for r in p.resumes]
    if data.status.faults:
        rows += [["fault", esc(f)] for f in data.status.faults]
    if data.validation is not None:
        v = data.validation.provenance
        rows.append(["validation session", esc(f"{v.session_path} ({v.software}, started "
                                               f"{v.created}, {data.validation.status.readings}"
                                               f" readings, {data.validation.status.status})")])
        if data.validation.note:
            rows.append(["validation note", esc(data.validation.note)])
    rows.append(["report made by", esc(f"{p.report_software} at {p.reported}")])
    return '<h2 id="provenance">Provenance</h2>' + _table(None, rows)


MACHINE_WORDS = {"leg_length_mm": ("leg length", "mm"), "rho_min_mm": ("Min posture", "mm"),
                 "rho_max_mm": ("Max posture", "mm"),
                 "gauge_resolution_mm": ("gauge resolution", "mm"),
                 "gauge_repeatability_mm": ("gauge repeatability", "mm")}


def machine_words(machine: dict) -> str:
    """``leg length 310.25 mm, Min posture -100.0 mm, ...``; unknown keys as they are."""
    parts = []
    for key, value in machine.items():
        words, unit = MACHINE_WORDS.get(key, (key, ""))
        parts.append(f"{words} {value}{' ' + unit if unit else ''}")
    return ", ".join(parts) or "not recorded"


def render_page(data: ReportData, figures: Sequence[FigureFile]) -> str:
    by_name = {f.name.removesuffix(".png"): f for f in figures}
    p = data.provenance
    machine = p.machine.get("name") or p.machine_file or "machine"
    title = f"Calibration report: {machine}, {p.created}"
    sections = [
        f"<h1>Calibration report {status_badge(data.status)}</h1>",
        f'<p class="sub">{esc(machine)} · session <code>{esc(p.session_path)}</code> · '
        f"started {esc(p.created)} · recorded by {esc(p.software)}"
        f"{' · simulated machine' if p.simulated else ''}</p>",
        _glance(data), _notes(data), _deviations(data, by_name), _parameters(data, by_name),
        _residuals(data, by_name), _identifiability(data), _diagnosis(data, by_name),
        _provenance(data),
        f"<footer>Made by {esc(p.report_software)} at {esc(p.reported)} from "
        f"{esc(p.session_path)}.</footer>"]
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">"
            f"<title>{esc(title)}</title><style>{STYLE}</style></head><body><main>"
            + "\n".join(s for s in sections if s) + "</main></body></html>\n")

