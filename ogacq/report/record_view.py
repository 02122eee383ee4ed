"""The calibration record (``ogacq-record/1``, docs/calibration-record.md section 5) as
the page's sections: every value of ``record.json`` in words and tables.

The sections follow what ISO/IEC 17025:2017 asks of a report: 7.8.2.1 (a unique
identification on every page and the end marked, the item, the method, the date of
the work and of issue, the results with their units, who authorises the report)
and 7.8.4.1 for a calibration (the uncertainty in the unit of the result, the
environmental conditions, the traceability of the instruments, the results
before and after an adjustment, the statement of conformity with its decision
rule, 7.8.6.1). A value the record does not hold is said ("not recorded", "not
evaluated"), with the record's reason, never left blank or shown as zero.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from markupsafe import Markup

from ogacq.history.entries import parameter_unit
from ogacq.identify.consistency import format_p
from ogacq.record.axis_scales import AxisScaleEntry, ScaleFound
from ogacq.record.calibration_record import CalibrationRecord
from ogacq.record.compensation import Iso230Stages, TableExported
from ogacq.record.declared import written
from ogacq.record.sections import (
    InstrumentEntry,
    NamedResult,
    ResultEntry,
    SessionFile,
    named_results,
)
from ogacq.report.cells import Badge, Cell, Fallback, Lines, Table, kinds, spaced, table
from ogacq.uncertainty.reporting import Headline, headline, rounded, two_digits

NOT_RECORDED = "not recorded"
NOT_EVALUATED = "not evaluated"

# Column and row names for the record's keys; other keys read with spaces for "_".
WORDS = Fallback({
    "value_mm": "value (mm)", "std_mm": "fit std (mm)", "u_mm": "u (mm)",
    "U_mm": "U (mm)", "k": "k", "u_input": "input u", "ambient_c": "ambient (°C)",
    "machine_c": "machine (°C)", "uncertainty_mm": "certificate U (mm)",
    "uncertainty_k": "certificate k", "resolution_mm": "resolution (mm)",
    "tolerance_mm": "tolerance (mm)", "deviation_mm": "deviation (mm)",
    "overshoot_mm": "overshoot (mm)", "settle_s": "settle (s)",
    "move_timeout_s": "move timeout (s)", "tolerance": "tolerance", "timeout_s": "timeout (s)",
    "leg_length_mm": "leg length (mm)", "rho_min_mm": "Min posture (mm)",
    "rho_max_mm": "Max posture (mm)", "gauge_resolution_mm": "gauge resolution (mm)",
    "gauge_repeatability_mm": "gauge repeatability (mm)", "noise_mm": "gauge noise σ (mm)",
    "chi2_dof": "χ² per dof", "p": "p", "dof": "dof",
    "leg_expansion_ppm_per_k": "leg expansion (ppm/K)", "dof_eff": "effective dof",
    "temperature_correction_mm": "correction to 20 °C (mm)", "complete": "budget complete",
    "u_c_mm": "budget u_c (mm)", "mean_mm": "mean (mm)", "interval_95_mm": "95 % interval (mm)",
    "ratio": "u / u_c", "agrees_within_10_percent": "agrees within 10 %",
    "converged_fraction": "converged fraction", "seconds": "time (s)",
}, spaced)
VERDICT_WORDS = Fallback({"p": "combined p (overall and worst cell, Bonferroni)",
                          "p_overall": "overall p",
                          "p_worst_cell": "worst cell's p (over the cells)",
                          "worst_cell": "worst cell"}, str)
# A null that is not an unknown: degrees of freedom of a type B input are infinite
# (JCGM 100:2008 G.4.2), and the uncertainty package writes them as null.
NULL_WORDS = {"dof": "∞", "dof_eff": "∞"}
DECISION_KIND = kinds({"pass": "ok", "fail": "bad", "undecided": "warn"})


def words(key: str) -> str:
    return WORDS[key]


def shown(value: Any, empty: str = NOT_RECORDED) -> str:
    """A JSON value as the page prints it: numbers in full (the digits record.json
    holds), booleans as yes/no, a table as ``key value, ...``, nothing as ``empty``."""
    if value == "":
        return ""  # nothing to say, as opposed to unknown
    if value is None or value == [] or value == {}:
        return empty
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return str(np.format_float_positional(value, trim="-"))
    if isinstance(value, Mapping):
        return ", ".join(f"{words(str(k))} " + (f"({shown(v, empty)})" if isinstance(v, Mapping)
                                                 else shown(v, empty))
                         for k, v in value.items())
    if isinstance(value, list | tuple):
        return ", ".join(shown(v, empty) for v in value)
    return str(value)


def signed_shown(value: Any, empty: str = NOT_EVALUATED) -> str:
    text = shown(value, empty)
    return f"+{text}" if isinstance(value, int | float) and not isinstance(value, bool) \
        and value > 0 else text


def decision_badge(decision: Any) -> Badge:
    text = shown(decision, NOT_EVALUATED)
    return Badge(text, DECISION_KIND[text])


def rows_table(rows: Sequence[Mapping[str, Any]], empty: str = NOT_RECORDED,
               first: Sequence[str] = ()) -> Table:
    """A table of dicts: one column per key (``first`` ones first), every key shown."""
    keys = list(first)
    for row in rows:
        keys += [k for k in row if k not in keys]
    filled = [{**dict.fromkeys(keys), **row} for row in rows]  # a key a row lacks: None
    body: list[list[Cell]] = [[cell(k, row[k], empty) for k in keys] for row in filled]
    numeric = [all(isinstance(r[k], int | float) and not isinstance(r[k], bool)
                   for r in filled if r[k] is not None) for k in keys]
    return table([words(k) for k in keys], body, numeric)


def cell(key: str, value: Any, empty: str) -> Cell:
    """One value of a table; a decision as its badge."""
    if key == "decision":
        return decision_badge(value)
    if key in NULL_WORDS:
        return shown(value, NULL_WORDS[key])
    return shown(value, empty)


def pairs_table(pairs: Mapping[str, Any], empty: str = NOT_RECORDED) -> Table:
    """Rows named by the keys."""
    return table(None, [[words(k), shown(v, empty)] for k, v in pairs.items()])


# --- the sections -------------------------------------------------------------------------

def identification(record: CalibrationRecord) -> Table:
    machine = record.machine_section
    campaign = record.campaign_section
    planned = f" of {shown(campaign.planned)} planned" if campaign.planned else ""
    reason = f" ({campaign.reason})" if campaign.reason else ""
    rehearsed = " (a simulated date: a rehearsal)" if record.date_simulated else ""
    rows: list[list[Cell]] = [
        ["record", shown(record.id)],
        ["record format", shown(record.format)],
        ["issued", shown(record.issued)],
        *_revision_rows(record),
        ["calibration date", shown(record.date) + rehearsed],
        ["machine", shown(machine.name)],
        ["machine serial number", shown(machine.serial)],
        ["machine description", shown(machine.file)],
        ["operator", shown(record.operator)],
        ["campaign", f"{shown(campaign.status)}{reason}: "
                     f"{shown(campaign.readings)} readings{planned}"]]
    if campaign.partial:
        rows.append(["campaign not finished", shown(campaign.partial)])
    rows += _session_rows("session", record.session_file)
    validation = record.validation_session_file
    if validation is not None:
        rows += _session_rows("as-left session", validation)
    return table(None, rows)


def revision_label(record: CalibrationRecord) -> str:
    """``OGQ-... revision 2``: how a re-issued record is named on every page; the first
    issue (and a record from before revisions) by its id alone."""
    revision = record.revision
    suffix = f" revision {revision}" if revision is not None and revision > 1 else ""
    return f"{record.id}{suffix}"


def _revision_rows(record: CalibrationRecord) -> list[list[Cell]]:
    """The issue's revision, the issue it replaces and what changed (ISO/IEC
    17025:2017 7.8.8)."""
    if "revision" not in record:
        return []
    rows: list[list[Cell]] = [["revision", shown(record.revision)]]
    revises = record.revises_section
    if revises is not None:
        rows.append(["replaces", f"revision {shown(revises.revision)} issued "
                                 f"{shown(revises.issued)} (its record.json SHA-256 "
                                 f"{shown(revises.sha256)})"])
        changes = [str(c) for c in record.changes or ()]
        rows.append([f"changed since revision {shown(revises.revision)}",
                     Lines(tuple(changes)) if changes else "nothing named"])
    return rows


# How a session vouches for its records (ogacq.session.seal), in a reader's words.
INTEGRITY_WORDS = Fallback({
    "sealed": "every record numbered, checksummed and chained to the one before",
    "unchecked": "written before ogacq checksummed its records: an edit cannot be found",
}, lambda _: "")


def _session_rows(what: str, session: SessionFile) -> list[list[Cell]]:
    """The session's file, SHA-256 and records, its integrity and the records the user
    accepted as edited."""
    rows: list[list[Cell]] = [[f"{what} file", shown(session.path)],
                              [f"{what} SHA-256", shown(session.sha256)],
                              [f"{what} records", shown(session.records)]]
    if not session.holds("integrity"):
        return rows
    mode = session.integrity
    rows.append([f"{what} integrity", f"{shown(mode)}: {INTEGRITY_WORDS[str(mode)]}"])
    rows += [[f"{what} edited record", f"line {shown(e.line)}: {shown(e.problem)} "
                                       "(accepted as it stands, --accept-edited)"]
             for e in session.edited]
    return rows


def instruments(record: CalibrationRecord) -> Table | None:
    """The gauges with their certificates; an expired one is marked, with its override."""
    found = record.instrument_entries
    if not found:
        return None
    return instruments_table(found, {(o.subject or "").split(" ")[0]
                                     for o in record.override_entries
                                     if o.what == "expired-gauge"})


def instruments_table(found: Sequence[InstrumentEntry], overridden: set[str]) -> Table:
    """Instruments with their certificates, one a row; an expired one marked, and said
    used under override where its gauge is ``overridden``."""
    shown_keys = ["gauge", "make", "model", "serial", "certificate", "calibrated", "due",
                  "uncertainty_mm", "uncertainty_k", "resolution_mm"]
    each = [written(i) for i in found]
    keys = list(dict.fromkeys([*shown_keys, *(k for i in each for k in i if k != "expired")]))
    header = [words(k) for k in keys] + ["certificate status"]
    rows: list[list[Cell]] = []
    kinds = []
    for instrument, values in zip(found, each, strict=True):
        row: list[Cell] = [shown(values[k]) if k in values else NOT_RECORDED for k in keys]
        expired = instrument.expired
        override = str(instrument.gauge) in overridden
        if expired:
            row.append(Badge("EXPIRED, used under override" if override else "EXPIRED", "bad"))
        elif expired is False:
            row.append(Badge("in date", "ok"))
        else:
            row.append(Badge("due date unknown", "warn"))
        rows.append(row)
        kinds.append("bad" if expired else "")
    numeric = [k.endswith(("_mm", "_k")) for k in shown_keys]
    return table(header, rows, numeric, kinds)


def environment(record: CalibrationRecord) -> Table | None:
    found = record.environment_stages
    if not found:
        return None
    return rows_table([{"stage": stage, **(written(values) if values else {})}
                       for stage, values in found.items()], first=("stage",))


def method(record: CalibrationRecord) -> Table:
    m = record.method_section
    rows: list[list[Cell]] = [
        *_named_rows("protocol", m.protocol), ["parameters identified", shown(m.params)],
        *_named_rows("identification", m.identification, NOT_EVALUATED),
        ["recorded by", shown(m.software)], ["record made by", shown(m.record_software)],
        ["decision rule", shown(m.decision_rule)]]
    if m.holds("offsets_in_force_mm"):
        rows.append(["joint offsets in force (the controller's, read at every start)",
                     _offsets_in_force(m.offsets_in_force_mm, m.offsets_in_force_consistent)])
    rows += [[words(k), shown(v)] for k, v in m.extra.items()]
    return table(None, rows)


def _named_rows(name: str, value: Any, empty: str = NOT_RECORDED) -> list[list[Cell]]:
    """One row of ``value``, or a row per key of a table (``protocol: cycles``)."""
    if isinstance(value, Mapping):
        return [[f"{name}: {words(k)}", shown(v)] for k, v in value.items()]
    return [[name, shown(value, empty)]]


def _offsets_in_force(offsets: Any, consistent: Any) -> str:
    """Every digit the controller gave (a register's step, or a software table's)."""
    if not isinstance(offsets, Mapping):
        return ("not recorded at every start of the campaign" if consistent is not False
                else "they changed between the starts of the campaign (it was resumed "
                     "after a change)")
    held = ", ".join(f"{shown(a)} {v:+}" if isinstance(v, float | int) else
                     f"{shown(a)} {shown(v)}" for a, v in offsets.items()) + " mm"
    return held if consistent is not False else \
        held + " at the first start; they changed at a later one (resumed after a change)"


# Results: the headline first (value ± U, k), then the detail, each rounded by the one
# rule (JCGM 100:2008 7.2.6); record.json keeps every digit.
HEADLINE_KEYS = ("value_mm", "U_mm", "k", "unit")
DETAIL_KEYS = ("u_mm", "std_mm", "dof_eff")


def results(entries: Sequence[NamedResult]) -> Table | None:
    """One row per parameter of ``results`` (or ``validation_results``)."""
    if not entries:
        return None
    each = [(n.name, n.entry, written(n.entry)) for n in entries]
    extra = list(dict.fromkeys(k for _, _, fields in each for k in fields
                               if k not in HEADLINE_KEYS + DETAIL_KEYS))
    rows: list[list[Cell]] = []
    for name, r, fields in each:
        rows.append([name, str(entry_headline(r)),
                     two_digits(r.u_mm) if r.u_mm is not None else NOT_EVALUATED,
                     two_digits(r.std_mm) if r.std_mm is not None else "not determined",
                     _dof(r.dof_eff, r.u_mm)]
                    + [_extra_cell(k, v, r.U_mm)
                       for k, v in (dict.fromkeys(extra) | fields).items() if k in extra])
    header = ["parameter", "value ± U", "u (mm)", "fit std (mm)", "effective dof"]
    return table(header + [words(k) for k in extra], rows,
                 [False, True, True, True, True] + [False] * len(extra))


def entry_headline(entry: ResultEntry, unit: str = "mm") -> Headline:
    """The headline of one parameter of the record's ``results`` (value ± U, k)."""
    return headline(entry.value_mm, entry.U_mm, entry.k, entry.unit or unit,
                    complete=entry.complete is not False)


def by_name(entries: Sequence[NamedResult]) -> dict[str, ResultEntry]:
    return {n.name: n.entry for n in entries}


def _extra_cell(key: str, value: Any, U_mm: float | None) -> Cell:
    """A result's other value: a length at U's decimal place, the rest as recorded."""
    if key.endswith("_mm") and isinstance(value, int | float):
        return rounded(value, U_mm, sign=True)
    return cell(key, value, NOT_EVALUATED)


def _dof(dof: float | None, u: float | None) -> str:
    """Effective degrees of freedom as a whole number; infinite (null with a u) as ∞."""
    if dof is not None:
        return f"{dof:.0f}"
    return "∞" if u is not None else NOT_EVALUATED


def verdict(record: CalibrationRecord) -> Table | None:
    found = record.verdict_section
    if found is None:
        return None
    # the verdict's p combines the overall test and the worst cell (Bonferroni): said
    # so, and each p named (p_combined repeats p: shown once)
    # a p-value as the terminal says it (3 digits, 2.8e-16; not 0.00000000000000028),
    # the misfit per dof too (its text's "per dof 532", not 532.2801 beside it)
    shown = {VERDICT_WORDS[k]: format_p(v) if _is_p(k, v)
             else f"{v:.3g}" if k == "chi2_dof" and isinstance(v, float) else v
             for k, v in written(found).items() if k != "p_combined"}
    return pairs_table(shown, NOT_EVALUATED)


def _is_p(key: str, value: Any) -> bool:
    return (key == "p" or key.startswith("p_")) and isinstance(value, float) \
        and math.isfinite(value)


def acceptance(record: CalibrationRecord) -> dict[str, Any]:
    found = record.acceptance_section
    stages = []
    for stage, title in ((found.as_found, "As found (this campaign)"),
                         (found.as_left, "As left (after the write-back)")):
        rows = [_deviation_row(r) for r in stage.rows]
        stages.append({"title": title, "badge": decision_badge(stage.decision),
                       "why": stage.why,
                       "table": rows_table(rows, NOT_EVALUATED) if rows else None,
                       "others": pairs_table(stage.extra, NOT_EVALUATED)
                       if stage.extra else None})
    return {"rule": shown(found.rule), "stages": stages}


def _deviation_row(row: Mapping[str, Any]) -> dict[str, Any]:
    """An acceptance row as a person reads it: the deviation at U's decimal place and U
    to two significant digits (JCGM 100:2008 7.2.6; record.json keeps every digit)."""
    out = dict(row)
    filled = {"value_mm": None, "U_mm": None} | out  # a key the row lacks: None
    value, U = filled["value_mm"], filled["U_mm"]
    if isinstance(value, float) and isinstance(U, float):
        out["value_mm"] = rounded(value, U, sign=True)
    if isinstance(U, float):
        out["U_mm"] = two_digits(U)
    return out


def budget(record: CalibrationRecord) -> list[tuple[str, Table]]:
    found = record.budget_rows
    first = ("source", "type", "distribution", "u_input", "unit", "sensitivity", "u_mm",
             "evaluated")
    return [(name, rows_table([{k: _figure(k, v) for k, v in written(r).items()}
                               for r in rows], NOT_EVALUATED, first))
            for name, rows in found.items()]


def monte_carlo(record: CalibrationRecord) -> tuple[Table, Table] | None:
    """The check's settings and verdict, then one row per parameter."""
    found = record.monte_carlo
    if not found:
        return None
    scalars = {k: v for k, v in found.items() if not isinstance(v, Mapping)}
    u_c = next((v for k, v in found.items() if k == "u_c_mm" and isinstance(v, Mapping)), {})
    u_floats = Fallback[float | None]({n: u for n, u in u_c.items() if isinstance(u, float)},
                                      lambda _: None)
    per = {k: {n: _figure(k, v, u_floats[n]) for n, v in values.items()}
           for k, values in found.items() if isinstance(values, Mapping)}
    names = list(dict.fromkeys(n for values in per.values() for n in values))
    # a parameter a figure lacks: None, "not evaluated"
    filled = [dict.fromkeys(names) | dict(values) for values in per.values()]
    rows: list[list[Cell]] = [[name, *(shown(values[name], NOT_EVALUATED) for values in filled)]
                              for name in names]
    return (pairs_table(scalars, NOT_EVALUATED),
            table(["parameter"] + [words(k) for k in per], rows,
                  [False] + [True] * len(per)))


PLACES = {"sensitivity": ".3g", "ratio": ".2f"}


def _figure(key: str, value: Any, u_c: float | None = None) -> Any:
    """A figure of the budget or of the Monte-Carlo check as a person reads it: an
    uncertainty (the input's u, a contribution, u_c) to two significant digits, as U is
    (JCGM 100:2008 7.2.6); a sensitivity to three (enough to give the contribution's
    two); the check's ratio to two decimals (judged against 10 %), its mean and its
    interval's ends at the decimal place of the budget's u_c. The page printed
    "0.000288675 mm" and "1.110040519"; record.json keeps every digit."""
    if key in ("u_input", "u_mm", "u_c_mm") and isinstance(value, float):
        return two_digits(value)
    if key in PLACES and isinstance(value, float):
        return f"{value:{PLACES[key]}}"
    if key.startswith(("mean", "interval")) and u_c is not None:
        ends = value if isinstance(value, list | tuple) else [value]
        return ", ".join(rounded(v, u_c, sign=key.startswith("mean")) for v in ends)
    return value


def history(record: CalibrationRecord) -> Table | None:
    found = record.history_entries
    if not found:
        return None
    each = [(e, {r.name: r.entry for r in named_results(e.results)}) for e in found]
    names = list(dict.fromkeys(n for _, results in each for n in results))
    rows: list[list[Cell]] = []
    units = {n: parameter_unit(n) for n in names}  # as the figure beside it draws them
    for entry, results in each:
        row: list[Cell] = [shown(entry.id), shown(entry.date)]
        for name in names:
            line = entry_headline(results[name], units[name]) \
                if name in results and written(results[name]) else None
            row.append("-" if line is None
                       else f"{line.value} ± {line.U}" if line.U else line.value)
        rows.append(row)
    return table(["record", "date"] + [f"{n} ({units[n]}) ± U (k = 2)" for n in names],
                 rows, [False, False] + [True] * len(names))


def overrides(record: CalibrationRecord) -> Table | None:
    found = record.override_entries
    if not found:
        return None
    return rows_table([written(o) for o in found],
                      first=("what", "subject", "due", "reason", "operator"))


def writebacks(record: CalibrationRecord) -> list[dict[str, Any]]:
    out = []
    for w in record.writeback_entries:
        kind = WRITE_KIND[str(w.status)]
        axes = sorted({*w.old_mm, *w.new_mm})
        old, new = dict.fromkeys(axes) | w.old_mm, dict.fromkeys(axes) | w.new_mm
        out.append({
            "badge": Badge(f"{shown(w.action)} {shown(w.status)}", kind),
            "when": shown(w.when), "details": shown(w.details),
            "table": table(["joint offset", "before (mm)", "after (mm)"],
                           [[a, signed_shown(old[a], "-"), signed_shown(new[a], "-")]
                            for a in axes], [False, True, True])})
    return out


WRITE_KIND = kinds({"done": "ok", "failed": "bad"}, "warn")
OUTCOME_KIND = kinds({"validated": "ok", "improved": "warn", "restored": "bad"})
ISO230_FIGURES = ("A", "B", "R", "E", "M")  # ISO 230-2:2014 clause 3, per axis


def compensation(record: CalibrationRecord) -> dict[str, Any] | None:
    """What ``ogacq calibrate`` wrote beside the offsets (docs/calibration-record.md 5,
    ``compensation``): its outcome, the error maps and their checksums, the ISO 230-2
    figures of each axis before and after, the tables exported; None without it."""
    comp = record.compensation_section
    if comp is None:
        return None
    outcome = shown(comp.outcome)
    maps_table = table(["axis", "the map corrects", "checksum (SHA-256)"],
                       [[a, shown(m.source), shown(m.checksum)]
                        for a, m in sorted(comp.maps.items())]) if comp.maps else None
    figures = _iso230_table(comp.iso230_2)
    return {"badge": Badge(f"calibrate {outcome}", OUTCOME_KIND[outcome]),
            "procedure": shown(comp.procedure), "reason": shown(comp.reason, ""),
            "writes": _operations(comp.writes) or "none",
            "restores": _operations(comp.restores),
            "maps": maps_table, "figures": figures,
            "compensated": ", ".join(comp.compensated) or "none",
            "uncompensated": ", ".join(comp.uncompensated) or "none",
            "tables": [f"{shown(t.format)}: {_table_outcome(t)}" for t in comp.tables]}


SCALE_KIND = kinds({"shown": "ok", "not shown": "warn", "worse": "bad"})


def axis_scales(record: CalibrationRecord) -> list[dict[str, Any]]:
    """Each axis's positioning tests by its scale (``axis_scales``): what the test
    before found, how the test after judged the map, the figures before and after in
    µm, the scale's identity and certificate; empty without scales."""
    out = []
    for axis, entry in sorted(record.axis_scale_entries.items()):
        rows: list[list[Cell]] = [
            [when, str(test.targets), str(test.runs), *(_um(v) for v in
                                                        test.iso230_2.in_order()),
             shown(test.session.path)]
            for when, test in (("before the write", entry.before),
                               ("after the write", entry.after)) if test is not None]
        out.append({
            "axis": axis, "badge": _scale_badge(entry), "found": _scale_found(entry.found),
            "figures": table(["when", "targets", "runs", *(f"{k} (µm)" for k in ISO230_FIGURES),
                              "session"], rows,
                             [False, True, True, *(True,) * len(ISO230_FIGURES)]),
            # a scale's expired certificate is overridden in its test's session, not
            # the campaign's: said expired, its override in that session
            "instrument": instruments_table((entry.instrument,), set())})
    return out


def _scale_badge(entry: AxisScaleEntry) -> Badge:
    check = entry.validation
    if check is None:
        return Badge("no map written on this axis: tested before the write only", "info")
    state = "worse" if check.worse else "shown" if check.shown else "not shown"
    said = f"{check.within} of {check.targets} targets within the map's U and the test's own"
    return Badge(f"{state}: {check.worse}" if check.worse else f"{state}: {said}",
                 SCALE_KIND[state])


def _scale_found(found: ScaleFound | None) -> str:
    """What the test before found along the axis, in words."""
    if found is None:
        return NOT_RECORDED
    if found.flat:
        return "flat: no error along the axis beyond the scale's noise, no map"
    if found.pitch_mm is None:
        return ("no cyclic error it resolves, though the axis is not flat within the "
                "scale's noise")
    U = 2 * found.pitch_std_mm if found.pitch_std_mm is not None else None
    return (f"a cyclic error of pitch {rounded(found.pitch_mm, U)} ± {two_digits(U)} mm "
            f"(k = 2), amplitude {_um(found.amplitude_mm)} µm: this axis's map")


def _operations(by_target: Mapping[str, str | None]) -> str:
    """``offsets write-81bd009e, maps maps-write-db716973``: the targets an operation
    wrote (or restored), by its id."""
    return ", ".join(f"{target} {operation}" for target, operation in by_target.items()
                     if operation)


def _iso230_table(stages: Iso230Stages) -> Table | None:
    """Each axis's ISO 230-2 figures before and after, in µm; None when none."""
    rows: list[list[Cell]] = []
    for axis in sorted({*stages.before, *stages.after}):
        for stage, when in ((stages.before, "before"),
                            (stages.after, "after (the validation campaign)")):
            if axis in stage:
                rows.append([axis, when, *(_um(v) for v in stage[axis].in_order())])
    return table(["axis", "when", *(f"{k} (µm)" for k in ISO230_FIGURES)], rows,
                 [False, False, *(True,) * len(ISO230_FIGURES)]) if rows else None


def _table_outcome(exported: TableExported) -> str:
    """The files a format wrote and, when the format or some of its axes were not
    written, why."""
    said = [", ".join(exported.files)] if exported.files else []
    if exported.problem:
        said.append(f"not written: {shown(exported.problem)}")
    return "; ".join(said)


def _um(value_mm: Any) -> str:
    """An ISO 230-2 figure in micrometres, to 0.01 µm (as the tables' comments)."""
    return f"{value_mm * 1000:.2f}" if isinstance(value_mm, int | float) else NOT_RECORDED


# What the page says of a section the record holds nothing of, where its ``missing``
# does not say why.
UNSAID = {"instruments": "no instrument is recorded", "environment": "no temperature is recorded",
          "results": "nothing was identified", "uncertainty": "no budget",
          "overrides": "overrides are not recorded", "monte_carlo": "no Monte-Carlo check"}


def why_missing(missing: Mapping[str, str]) -> dict[str, str]:
    """Why each section is empty: the record's reason, else the page's words; the
    Monte-Carlo check's, the uncertainty's when the record gives none of its own."""
    check = next((missing[k] for k in ("monte_carlo", "uncertainty") if k in missing),
                 UNSAID["monte_carlo"])
    return UNSAID | dict(missing) | {"monte_carlo": check}


def record_view(record: CalibrationRecord) -> dict[str, Any]:
    """The template's values for the record's sections."""
    missing = record.missing_reasons
    return {
        "rec": record, "revises": record.revises_section,
        "identification": identification(record), "record_missing": missing,
        "why_missing": why_missing(missing),
        "missing": [(words(k), v) for k, v in missing.items()],
        "instruments": instruments(record), "environment": environment(record),
        "method": method(record), "results": results(record.result_entries),
        "verdict": verdict(record),
        "validation_results": results(record.validation_result_entries),
        "acceptance": acceptance(record), "budget": budget(record),
        "budget_complete": record.budget_complete,
        "monte_carlo": monte_carlo(record), "history": history(record),
        "overrides": overrides(record), "record_writes": writebacks(record),
        "compensation": compensation(record), "axis_scales": axis_scales(record),
        "page_footer": css_string(f"Calibration record {revision_label(record)}"),
        "record_label": revision_label(record),
    }


def css_string(text: str) -> str:
    """``text`` as a CSS string literal for the print stylesheet's page margins
    (CSS Syntax Level 3, 4.3.5: a backslash escapes the quote and itself; a
    newline cannot stand in a string). Angle brackets are escaped too (4.3.7,
    ``\\3c``), so nothing in it can close the page's style element."""
    escaped = (text.replace("\\", "\\\\").replace('"', '\\"').replace("\n", " ")
               .replace("<", "\\3c ").replace(">", "\\3e "))
    return Markup(f'"{escaped}"')
