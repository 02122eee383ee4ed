"""The supporting analysis of the report: what the page shows beside the calibration
record and the record does not hold, taken from the same session (and optionally a
validation session and a diagnosis) as plain values.

One path: what the record (``ogacq-record/1``, ``ogacq.record.document``) holds, the
page reads from the record: the campaign's status, readings and planned readings,
the results with their uncertainty, the verdict, the write-backs (built by
``ogacq.session.state.campaign_status`` and ``ogacq.writeback.audit.offsets_writes``,
which the record calls). What stays here is what no record carries:
- the figures' arrays: the papers' twelve deviations before ("before": Max/Min
  relative to Zero, averaged over cycles), after as predicted (the same averages of
  the residuals: what remains once the identified offsets are compensated) and after
  as measured (a validation campaign run after the write-back); the residual of each
  reading; the residuals of each step of a diagnosis, refitted here;
- the fit's statistics beyond its results (residual rms, the sigma it implies, dof,
  rank, condition number, correlated pairs, why a parameter is not determined) and
  each parameter at the fit's own precision (the record rounds to 1 nm; the figures
  and the analysis tables keep the fit's digits);
- what the session's header and records say beyond the record: the station, the
  resumes, the campaign's length, other tools' header entries, the faults met, the
  records a crash cut; and the validation campaign's status and fit (the record
  keeps only its results).
The identification is the campaign's own, as it recorded it
(:func:`ogacq.session.identification.recorded_identification`), as the record's is, so the
analysis shows the numbers the campaign printed and the record states.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any, TypeVar

import numpy as np

from ogacq import __version__
from ogacq.identify.fit import FitResult, fit
from ogacq.identify.observations import Deviation, Observations, averaged_deviations
from ogacq.io.dates import local_time_text
from ogacq.io.errors import InputError
from ogacq.model.measurement import POSTURE_NAMES
from ogacq.model.parameters import AXES, PARAM_INDEX, effect_of
from ogacq.record.declared import RecordSectionError, Section, read
from ogacq.record.sections import RecordMachine
from ogacq.report.cells import Fallback
from ogacq.report.diagnosis_view import DiagnosisView
from ogacq.session.convert import session_machine
from ogacq.session.identification import recorded_identification
from ogacq.session.json_document import JsonObject
from ogacq.session.records import FaultRecord, ResumeRecord
from ogacq.session.state import CampaignStatus, campaign_status
from ogacq.session.store import LoadedSession

POSTURE_OF_SIGN = {"+": "max", "-": "min"}
# how a campaign that did not finish ended, in words
UNFINISHED_WORDS = Fallback({"stopped": "stopped before its end",
                             "interrupted": "was interrupted",
                             "incomplete": "did not finish (no end record)"}, str)
S = TypeVar("S", bound=Section)


@dataclass(frozen=True)
class ParameterRow:
    name: str
    unit: str
    value: float
    std: float  # NaN or inf when the data do not determine it


@dataclass(frozen=True)
class FitSummary:
    """One identification of the joint offsets, as the report states it."""

    parameters: tuple[ParameterRow, ...]
    n_readings: int
    residual_rms_mm: float
    sigma_mm: float  # the noise the residuals imply
    dof: int
    noise_mm: float  # the gauge noise the std are propagated from
    noise_source: str
    noise_dof: int | None
    rank: int
    condition_number: float
    identifiable: bool
    reasons: tuple[str, ...]
    correlated_pairs: tuple[tuple[str, str, float], ...]
    method: str

    @property
    def misfit_ratio(self) -> float:
        """Residual scatter over gauge noise: about 1 when the model explains the data."""
        return self.sigma_mm / self.noise_mm if self.noise_mm > 0 else float("nan")

    def row(self, name: str) -> ParameterRow | None:
        return next((p for p in self.parameters if p.name == name), None)


@dataclass(frozen=True)
class DeviationRow:
    name: str  # the papers' name: dy_x+ is along y on the x leg at Max
    leg: str
    gauge_axis: str
    posture: str  # "max" or "min"
    before_mm: float
    noise_mm: float  # 1 sigma of this deviation from the gauge noise (averaging included)
    after_predicted_mm: float
    after_measured_mm: float | None = None


@dataclass(frozen=True)
class ResidualSeries:
    """Residuals per reading, in the order taken (gauge zeros removed)."""

    number: np.ndarray  # 1-based position in the session
    residual_mm: np.ndarray
    leg: tuple[str, ...]
    gauge: tuple[str, ...]


@dataclass(frozen=True)
class ModelStep:
    """Residuals of the joint offsets plus the effects found so far (diagnosis)."""

    label: str
    names: tuple[str, ...]
    residuals: ResidualSeries
    rms_mm: float


@dataclass(frozen=True)
class Provenance:
    session_path: str
    software: str  # that recorded the session
    created: str
    machine: dict[str, Any]
    machine_name: str | None  # the machine file's name
    machine_file: str | None
    campaign_file: str | None
    station: tuple[tuple[str, str], ...]  # (what, description)
    simulated: bool
    simulator: dict[str, Any] | None
    plan: PlanSummary | None
    resumes: tuple[str, ...]
    campaign_time_s: float | None  # station clock at the last reading
    other: tuple[tuple[str, str], ...]  # header entries of other tools (the wizard's, ...)
    report_software: str = f"ogacq {__version__}"
    reported: str = field(default_factory=lambda: time.strftime("%Y-%m-%dT%H:%M:%S%z"))


@dataclass(frozen=True)
class ValidationRun:
    provenance: Provenance
    status: CampaignStatus
    fit: FitSummary | None
    note: str | None


@dataclass(frozen=True)
class ReportData:
    provenance: Provenance
    faults: tuple[str, ...]  # the faults the campaign met, in words
    fit: FitSummary | None
    deviations: tuple[DeviationRow, ...]
    residuals: ResidualSeries | None
    validation: ValidationRun | None
    diagnosis: DiagnosisView | None
    diagnosis_steps: tuple[ModelStep, ...]
    diagnosis_note: str | None
    # what a reader must know before trusting the numbers, after what the record says
    # of its campaign (a partial one): a record cut by a crash, a fit that failed
    notes: tuple[str, ...]
    # the identifications summarised above (recorded_identification of each session),
    # handed to the record so that it does not identify them again
    identified: FitResult | None = None
    validation_identified: FitResult | None = None


# --- the session as a campaign ------------------------------------------------------------

@dataclass(frozen=True)
class PlanSummary(Section):
    """The header's ``plan`` (``ProtocolConfig.to_dict``) as the page states it; a
    scan has no postures."""

    legs: tuple[str, ...] = ()
    postures: tuple[str, ...] = ()
    cycles: int | None = None
    approach: str | None = None


@dataclass(frozen=True)
class StationSummary(Section):
    """The header's ``station``: the controller and gauges opened, each a table as
    recorded; every other key (a deadline, the integrity, ...) kept in ``extra``."""

    controller: Any = None
    gauges: Any = None
    simulated: Any = None


def _header_section(session: LoadedSession, cls: type[S], key: str,
                    found: JsonObject | None) -> S | None:
    """The header's ``key`` (``found``, None when absent), an InputError naming the
    file and the key when it is not what ogacq writes."""
    try:
        return None if found is None else read(cls, found, key)
    except RecordSectionError as exc:
        raise InputError(session.path, f"the header's {exc.key} {exc.problem_of_key}") from None


def provenance(session: LoadedSession) -> Provenance:
    h = session.header
    station = _header_section(session, StationSummary, "station", h.station) or StationSummary()
    machine = _header_section(session, RecordMachine, "machine", h.machine) or RecordMachine()
    described: list[tuple[str, str]] = []
    if isinstance(station.controller, dict):
        described.append(("axis controller", _describe(station.controller)))
    if isinstance(station.gauges, dict):
        for name, g in station.gauges.items():
            described.append((f"gauge {name}", _describe(g) if isinstance(g, dict) else str(g)))
    for key, value in station.extra.items():
        described.append((key.replace("_", " "), _describe(value)
                          if isinstance(value, dict) else str(value)))
    resumes = tuple(f"{local_time_text(r.wall)} with {r.software}"
                    for r in session.of_type(ResumeRecord))
    times = [r.t_s for r in session.readings]
    simulator = dict(h.simulator) if h.simulator is not None else None
    return Provenance(
        session_path=str(session.path), software=h.software or "unknown",
        created=h.created or "unknown",
        machine=dict(h.machine or {}), machine_name=machine.name,
        machine_file=h.machine_file,
        campaign_file=h.campaign_file, station=tuple(described),
        simulated=bool(station.simulated) or simulator is not None,
        simulator=simulator, plan=_header_section(session, PlanSummary, "plan", h.plan),
        resumes=resumes, campaign_time_s=max(times) if times else None,
        other=tuple((key.replace("_", " "), _describe_value(value))
                    for key, value in h.to_json().items()
                    if key not in KNOWN_HEADER and value not in (None, "", [], {})))


def _describe_value(value: object) -> str:
    """A header value in words: a table as ``key value``, a list of tables (the
    instruments) one after the other."""
    if isinstance(value, dict):
        return _describe(value)
    if isinstance(value, list):
        return "; ".join(_describe_value(item) for item in value)
    return str(value)


# identity, instruments and date are the record's (its identification and
# instruments sections show them), not provenance to list again
KNOWN_HEADER = frozenset({"type", "format", "software", "created", "machine", "machine_file",
                          "campaign_file", "station", "simulator", "plan", "identity",
                          "instruments", "date"})


def _describe(d: dict) -> str:
    """``key value, ...`` in words; a nested table (a reconnect policy, offsets by axis)
    in parentheses the same way, never as a Python dict."""
    return ", ".join(f"{str(k).replace('_', ' ')} " + (f"({_describe(v)})" if isinstance(v, dict)
                                                      else str(v))
                     for k, v in d.items() if v not in (None, "", [], {}))



# --- identification -----------------------------------------------------------------------

def summarise(result: FitResult) -> FitSummary:
    ident = result.identifiability
    rows = tuple(ParameterRow(n, effect_of(n).unit, float(v), float(s))
                 for n, v, s in zip(result.names, result.values, result.std, strict=True))
    return FitSummary(
        parameters=rows, n_readings=len(result.observations),
        residual_rms_mm=result.residual_rms_mm, sigma_mm=result.sigma_mm, dof=result.dof,
        noise_mm=result.noise.sigma_mm, noise_source=result.noise.source,
        noise_dof=result.noise.dof, rank=ident.rank,
        condition_number=ident.condition_number, identifiable=ident.identifiable,
        reasons=tuple(ident.reasons), correlated_pairs=tuple(ident.correlated_pairs),
        method=result.method)


def residual_series(session: LoadedSession, residual_mm: np.ndarray) -> ResidualSeries:
    rows = session.readings
    return ResidualSeries(np.arange(1, len(rows) + 1), np.asarray(residual_mm, dtype=float),
                          tuple(r.leg for r in rows), tuple(r.gauge.key for r in rows))


def _deviation_noise(obs: Observations, sigma_mm: float) -> dict[str, float]:
    """1-sigma noise of each averaged deviation: its Max (or Min) mean and its Zero mean
    are averages of independent readings."""
    lay = obs.layout
    postures = lay.posture_names(obs.machine)
    out = {}
    for j, i in lay.gauge_keys:
        sel = (lay.gauge_axis == j) & (lay.leg == i)
        count = {p: int(np.sum(postures[sel] == p)) for p in POSTURE_NAMES}
        for sign, posture in POSTURE_OF_SIGN.items():
            if count[posture] and count["zero"]:
                out[f"d{AXES[j]}_{AXES[i]}{sign}"] = sigma_mm * float(
                    np.sqrt(1 / count[posture] + 1 / count["zero"]))
    return out


def _named(obs: Observations) -> dict[str, float]:
    try:
        dev = averaged_deviations(obs, "12")
    except ValueError:  # no Zero/Max/Min postures in these readings
        return {}
    return dict(zip(dev.labels, dev.values.tolist(), strict=True))


def deviation_rows(result: FitResult, validation: FitResult | None) -> tuple[DeviationRow, ...]:
    obs = result.observations
    before = _named(obs)
    after = _named(replace(obs, values=result.residuals))
    noise = _deviation_noise(obs, result.noise.sigma_mm)
    # a deviation the fit or the validation does not have: NaN, None (not measured)
    measured: dict[str, float | None] = dict.fromkeys(before)
    if validation is not None:
        measured |= _named(validation.observations)
    unknown = dict.fromkeys(before, float("nan"))
    noise, after = unknown | noise, unknown | after
    rows = []
    for name, value in before.items():
        deviation = Deviation.parse(name)
        rows.append(DeviationRow(name, deviation.gauge.leg, deviation.gauge.axis,
                                 deviation.posture, value, noise[name], after[name],
                                 measured[name]))
    order = {leg: k for k, leg in enumerate(AXES)}
    return tuple(sorted(rows, key=lambda r: (order[r.leg], r.posture != "max", r.gauge_axis)))


def diagnosis_steps(result: FitResult, session: LoadedSession,
                    view: DiagnosisView) -> tuple[tuple[ModelStep, ...], str | None]:
    """Refit the joint offsets plus the diagnosis's effects one at a time, in the order
    the diagnosis lists them, to show the residuals each one removes."""
    steps = [ModelStep("joint offsets only", result.names, residual_series(
        session, result.residuals), result.residual_rms_mm)]
    names = list(result.names)
    for effect in view.named_effects:
        if effect.located is not None:  # an error map: its residuals are the profiles'
            continue
        if effect.name not in PARAM_INDEX:
            return tuple(steps), f"{effect.name} is not a parameter this version can fit"
        names.append(effect.name)
        step = fit(result.observations, names, noise=result.noise)
        if not step.converged or not np.all(np.isfinite(step.residuals)):
            return tuple(steps), f"the refit with {effect.name} did not converge"
        steps.append(ModelStep(f"+ {effect.name}", tuple(names),
                               residual_series(session, step.residuals), step.residual_rms_mm))
    return tuple(steps), None


# --- the whole report ---------------------------------------------------------------------

def _identify(session: LoadedSession) -> tuple[FitResult | None, str | None]:
    if not session.readings:
        return None, "the session holds no readings: there is nothing to identify"
    try:
        return recorded_identification(session), None
    except (ValueError, InputError) as exc:
        return None, f"the joint offsets could not be identified: {exc}"


def status_notes(status: CampaignStatus, what: str = "campaign") -> list[str]:
    """What a campaign that did not finish means for what the page shows, and each
    record a crash cut."""
    notes = []
    if not status.complete:
        planned = f" of {status.planned} planned" if status.planned else ""
        why = f" ({status.reason})" if status.reason else ""
        state = UNFINISHED_WORDS[status.status]
        notes.append(f"This {what} {state}{why}: {status.readings} readings{planned}. "
                     "Everything below comes from the readings on file only; legs or "
                     "postures that were not read cannot show.")
    return notes + torn_notes(status.torn)


def torn_notes(warnings: Sequence[str]) -> list[str]:
    """Each record a crash cut (the session's load warnings), as the page says it."""
    return [f"A record cut by a crash was dropped: {w}" for w in warnings]


def collect(session: LoadedSession, *, validation: LoadedSession | None = None,
            diagnosis: DiagnosisView | None = None,
            diagnosis_note: str | None = None) -> ReportData:
    notes = torn_notes(session.warnings)
    result, problem = _identify(session)
    if problem:
        notes.append(problem)
    elif result is not None and not result.converged:
        notes.append(f"the fit did not converge ({result.stop_reason.describe()}): "
                     "treat the offsets with suspicion")

    validation_run, validation_fit = None, None
    if validation is not None:
        v_status = campaign_status(validation)
        validation_fit, v_problem = _identify(validation)
        v_notes = status_notes(v_status, "validation campaign") + ([v_problem] if v_problem
                                                                     else [])
        if session_machine(validation) != session_machine(session):
            v_notes.append("the validation session was recorded with another machine "
                           "description than the calibration session")
        validation_run = ValidationRun(provenance(validation), v_status,
                                       summarise(validation_fit) if validation_fit else None,
                                       " ".join(v_notes) or None)

    steps: tuple[ModelStep, ...] = ()
    if diagnosis is not None and result is not None:
        steps, step_note = diagnosis_steps(result, session, diagnosis)
        if step_note:
            diagnosis_note = "; ".join(n for n in (diagnosis_note, step_note) if n)

    return ReportData(
        provenance=provenance(session),
        faults=tuple(f.describe() for f in session.of_type(FaultRecord)),
        fit=summarise(result) if result is not None else None,
        deviations=deviation_rows(result, validation_fit) if result is not None else (),
        residuals=residual_series(session, result.residuals) if result is not None else None,
        validation=validation_run, diagnosis=diagnosis, diagnosis_steps=steps,
        diagnosis_note=diagnosis_note, notes=tuple(notes),
        identified=result, validation_identified=validation_fit)

