"""The calibration record as one JSON document (``ogacq-record/1``,
docs/calibration-record.md section 5): what the report page shows, in a form a
program reads (``record.json`` beside ``report.html``).

Nothing is invented. A value the session does not hold (an old session has no
operator, no certificates, no temperatures) is ``null`` and the record's
``missing`` table says why, in words the page repeats; an uncertainty that was not
evaluated is not a zero.

ISO/IEC 17025:2017 7.8.2.1 lists what a report holds (a unique identification,
the item, the method, the dates, the results with their units, who authorises it)
and 7.8.4.1 what a calibration certificate adds (the measurement uncertainty, the
environmental conditions, the traceability, the results before and after an
adjustment, the statement of conformity); the sections below follow them.
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import math
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from ogacq import __version__
from ogacq.identify.consistency import fit_verdict
from ogacq.identify.fit import FitResult
from ogacq.io.errors import InputError
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import effect_of
from ogacq.record.context import CalibrationContext, calibration_context
from ogacq.record.evaluation import evaluate
from ogacq.record.identity import record_id, session_digest
from ogacq.session.convert import session_machine
from ogacq.session.header import SessionHeader
from ogacq.session.identification import recorded_identification
from ogacq.session.offsets_in_force import offsets_in_force
from ogacq.session.state import campaign_status, completeness
from ogacq.session.store import LoadedSession
from ogacq.writeback.audit import offsets_writes

FORMAT = "ogacq-record/1"

# Why a section holds nothing: a session recorded before ogacq asked for it, or one
# whose campaign file and operator left it out.
NOT_IN_SESSION = "the session does not record {what} (recorded before ogacq asked for it)"
NOT_GIVEN = "{what}: not given when the campaign ran"


def build_record(session: LoadedSession, *, validation: LoadedSession | None = None,
                 history: Sequence[Mapping[str, Any]] | None = None, history_why: str | None = None,
                 issued: str | None = None, compensation: Mapping[str, Any] | None = None,
                 fit: FitResult | None = None,
                 validation_fit: FitResult | None = None) -> dict[str, Any]:
    """The record of the calibration campaign ``session``.

    ``validation``: the campaign run after the write-back (the as-left measurement);
    ``history``: earlier calibrations of the same machine, each ``{"id", "date",
    "results"}`` with ``results`` shaped as this record's (``history_why``: why
    there is none, when None is given); ``issued``: the issue
    time (default: now, ISO 8601 with offset); ``compensation``: what ``ogacq
    calibrate`` wrote and found (the maps, the ISO 230-2 figures before and after,
    its outcome), recorded under that key when given. The identity, instruments,
    environment and overrides are the session's own (:func:`calibration_context`).
    ``fit`` / ``validation_fit``: the session's (the validation's) identification
    as the caller already computed it, which must be ``recorded_identification`` of
    that session (the report's data is); None: identified here (a saved file).
    The fit a campaign ran is not that one (the record evaluates the result the
    session recorded, so a record built later from the file is the same)."""
    header_line, sha256 = session_digest(session)
    header = session.header
    machine = dict(header.machine or {})
    context = calibration_context(session)
    date = _text(context.date)
    missing: dict[str, str] = {}
    result, why_no_fit = (fit, None) if fit is not None else _identify(session)
    if why_no_fit:
        missing["results"] = why_no_fit
    left, why_no_left = _as_left(validation, validation_fit)
    as_left = (left, calibration_context(validation)) \
        if left is not None and validation is not None else None
    evaluation = evaluate(result, context, as_left, why_no_left, machine=_machine(session))

    record: dict[str, Any] = {
        "format": FORMAT,
        "id": record_id(header_line, date),
        "issued": issued or dt.datetime.now().astimezone().isoformat(timespec="seconds"),
        "machine": {"name": context.machine_name, "serial": context.machine_serial,
                    "file": machine},
        "operator": context.operator,
        "date": date,
        "date_simulated": context.simulated_date,
        "simulated": simulated(header),
        **_context_sections(context, "instruments" in header, missing),
        "campaign": _campaign(session),
        "method": _method(session, result, machine),
        "results": _results(result, evaluation.results) if result is not None else None,
        "budget": evaluation.budget,
        "budget_complete": evaluation.budget_complete,
        "monte_carlo": evaluation.monte_carlo,
        "acceptance": evaluation.acceptance,
        "verdict": _verdict(result) if result is not None else None,
        "writeback": [_write(w) for w in offsets_writes(session)],
        "history": [_history_entry(h) for h in history or ()],
        "session": _session_reference(session, sha256),
        "validation_session": (_session_reference(validation) if validation is not None
                               else None),
        # what the validation identified (the offsets remaining after the write-back)
        "validation_results": (_results(left, evaluation.validation_results)
                               if left is not None else None),
    }
    _said_missing(record, session, missing)
    if history is None and history_why:
        missing["history"] = history_why
    record["missing"] = missing | evaluation.missing
    if compensation is not None:
        record["compensation"] = plain(compensation)
    return record


def _as_left(validation: LoadedSession | None, validation_fit: FitResult | None,
             ) -> tuple[FitResult | None, str | None]:
    """The as-left campaign's identification, or why there is none (None, None: no
    as-left campaign)."""
    if validation is None:
        return None, None
    if validation_fit is not None:
        return validation_fit, None
    left, why_not = _identify(validation)
    return (left, None) if left is not None else (None, f"the as-left campaign: {why_not}")


def _said_missing(record: Mapping[str, Any], session: LoadedSession,
                  missing: dict[str, str]) -> None:
    """The operator and the machine's serial, where the record has none: why (not
    given when the campaign ran, or a session from before ogacq asked)."""
    why_none = NOT_GIVEN if "identity" in session.header else NOT_IN_SESSION
    if record["operator"] is None:
        missing.setdefault("operator", why_none.format(what="the operator"))
    if record["machine"]["serial"] is None:
        missing["machine serial"] = why_none.format(what="the machine's serial number")


# --- the parts ----------------------------------------------------------------------------

def simulated(header: SessionHeader) -> bool | None:
    """Whether the campaign ran on the built-in simulator: the header's ``simulated``,
    or (sessions before it) its station's; None where the session does not say
    (an imported table)."""
    for said in (header.simulated, (header.station or {}).get("simulated")):
        if isinstance(said, bool):
            return said
    return True if header.simulator else None


def _session_reference(session: LoadedSession, sha256: str | None = None) -> dict[str, Any]:
    """Where the record's evidence is: the session file (absolute path), its SHA-256
    as loaded, its number of records after the header, how it vouches for them
    (``integrity``: sealed or unchecked) and the records the user
    accepted as edited (``ogacq.session.seal``)."""
    if sha256 is None:
        _, sha256 = session_digest(session)
    integrity = session.integrity.to_json()
    return {"path": str(Path(session.path).resolve()), "sha256": sha256,
            "records": len(session.records), "integrity": integrity["integrity"],
            "edited": integrity["edited"]}


def _machine(session: LoadedSession) -> MachineSpec | None:
    """The machine the session describes (its tolerances), None when it cannot say."""
    try:
        return session_machine(session)
    except (InputError, ValueError, TypeError):
        return None


def _identify(session: LoadedSession) -> tuple[FitResult | None, str | None]:
    if not session.readings:
        return None, "the session holds no readings: nothing was identified"
    try:
        return recorded_identification(session), None
    except (ValueError, InputError) as exc:
        return None, f"the joint offsets could not be identified: {exc}"


def _context_sections(context: CalibrationContext, recorded: bool,
                      missing: dict[str, str]) -> dict[str, Any]:
    """Instruments, environment and overrides as the session recorded them.
    ``recorded``: the session records its instruments (a session from before has
    only its gauges' serials, and no expired-gauge check ran, so no override)."""
    instruments = [dict(i.to_json(), expired=context.expired(i)) for i in context.instruments]
    environment = context.environment.to_json()
    why_none = NOT_GIVEN if recorded else NOT_IN_SESSION
    if not instruments:
        missing["instruments"] = why_none.format(what="the instruments")
    elif not any(i["certificate"] for i in instruments):
        missing["certificates"] = why_none.format(what="the instruments' calibration certificates")
    if not any(environment.values()):
        missing["environment"] = why_none.format(what="the temperatures")
    overrides: list[dict[str, Any]] | None = [o.to_json() for o in context.overrides]
    if not recorded and not overrides:
        overrides = None
        missing["overrides"] = ("the session records no instruments, so no expired-gauge "
                                "check ran and no override could be recorded")
    return {"instruments": instruments, "environment": environment, "overrides": overrides}


def _campaign(session: LoadedSession) -> dict[str, Any]:
    status = campaign_status(session)
    state = completeness(session)
    return {"status": status.status, "readings": status.readings, "planned": status.planned,
            "reason": status.reason, "partial": None if state.complete else state.describe()}


def _method(session: LoadedSession, result: FitResult | None,
            machine: Mapping[str, Any]) -> dict[str, Any]:
    tolerances = machine.get("tolerances")
    recorded = session.result
    return {
        "protocol": session.header.plan,
        "params": recorded.params if recorded is not None else "offsets",
        "identification": None if result is None else {
            "method": result.method, "weighting": result.weighting,
            "readings": len(result.observations),
            "noise_mm": number(result.noise.sigma_mm), "noise_source": result.noise.source},
        "software": _text(session.header.software),
        "record_software": f"ogacq {__version__}",
        "controller": _controller(session),
        "decision_rule": (tolerances.get("decision_rule")
                          if isinstance(tolerances, Mapping) else None),
        # what the identified offsets are relative to (q = raw - o): the write-back
        # plans from it, the history compares calibrations by it
        **_offsets_in_force(session),
    }


def _controller(session: LoadedSession) -> dict[str, Any]:
    """The controller the campaign ran with: its profile as named, the profile's own
    name and its file's SHA-256 (one identity whether built in or given as a file; null
    for sessions recorded before they were), and what each drive said it is (Read
    Device Identification: vendor, product, revision; null where a drive did not answer
    it, and the whole null for sessions recorded before it was asked)."""
    controller = (session.header.station or {}).get("controller") or {}
    return {"profile": _text(controller.get("profile")),
            "profile_name": _text(controller.get("profile_name")),
            "profile_sha256": _text(controller.get("profile_sha256")),
            "identification": controller.get("identification")}


def _offsets_in_force(session: LoadedSession) -> dict[str, Any]:
    found = offsets_in_force(session)
    return {"offsets_in_force_mm": found.offsets_mm,
            "offsets_in_force_consistent": found.consistent}


def _results(result: FitResult, budget_results: Mapping[str, Any] | None,
             ) -> dict[str, dict[str, dict[str, Any]]]:
    """Each parameter's value, the fit's standard deviation (the gauge noise propagated
    through the fit alone, JCGM 100:2008 4.2, a type A evaluation) and, from the
    budget, its u, U = k u and how complete that is."""
    budget = budget_results or {}
    out: dict[str, dict[str, dict[str, Any]]] = {}
    for name, value, std in zip(result.names, result.values, result.std, strict=True):
        group, _, where = name.partition(".")
        evaluated = (budget.get(group) or {}).get(where) or {}
        out.setdefault(group, {})[where] = {
            "value_mm": number(value), "std_mm": number(std), "u_mm": None, "U_mm": None,
            "k": None, **evaluated, "unit": effect_of(name).unit}
    return out


def _verdict(result: FitResult) -> dict[str, Any]:
    verdict = fit_verdict(result)
    cell = verdict.worst_cell
    # "p" is the verdict's, judged against the level: the overall test's and the worst
    # cell's Bonferroni-combined (the smaller, doubled); the keys after it say each
    return {"state": verdict.state, "consistent": verdict.consistent,
            "chi2_dof": number(verdict.chi2_dof, 4), "p": number(verdict.p_value, 4),
            "test": verdict.test, "dof": verdict.dof, "level": verdict.level,
            "text": verdict.describe(),
            "p_overall": number(verdict.overall_p, 4) if verdict.judged else None,
            "p_worst_cell": number(cell.p_value, 4) if cell is not None else None,
            "worst_cell": cell.cell if cell is not None else None,
            "p_combined": number(verdict.p_value, 4) if verdict.judged else None}


def _write(write: Any) -> dict[str, Any]:
    return {"action": write.action, "status": write.status, "when": write.when,
            "old_mm": {k: number(v) for k, v in sorted(write.old_mm.items())},
            "new_mm": {k: number(v) for k, v in sorted(write.new_mm.items())},
            "details": write.details}


def _history_entry(entry: Mapping[str, Any]) -> dict[str, Any]:
    """An earlier calibration as the caller gave it: its id, date and results."""
    if not isinstance(entry, Mapping) or "date" not in entry:
        raise ValueError(f"a history entry needs an id, a date and results: {entry!r}")
    results = entry.get("results")
    return {"id": _text(entry.get("id")), "date": _text(entry.get("date")),
            "results": plain(results) if isinstance(results, Mapping) else {}}


# --- JSON values --------------------------------------------------------------------------

def number(x: Any, digits: int = 6) -> float | None:
    """A finite float rounded to ``digits`` decimals (mm: 1 nm), or None: JSON has no
    NaN, and an undetermined value is unknown, not a number."""
    try:
        value = float(x)
    except (TypeError, ValueError):
        return None
    if not math.isfinite(value):
        return None
    if digits >= 0 and value != 0 and abs(value) < 10.0 ** -digits:
        return float(f"{value:.{max(1, digits - 2)}g}")  # keep a tiny number's digits
    return round(value, digits)


def plain(value: Any) -> Any:
    """A dataclass, mapping, sequence, date or number as JSON values."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: plain(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, Mapping):
        return {str(k): plain(v) for k, v in value.items()}
    if isinstance(value, dt.date | dt.datetime | dt.time):
        return value.isoformat()
    if value is None or isinstance(value, str | int):  # a bool is an int
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, Path):
        return str(value)
    return [plain(v) for v in value] if isinstance(value, Iterable) else str(value)


def _text(value: Any) -> str | None:
    if value is None or value == "":
        return None
    return value.isoformat() if isinstance(value, dt.date | dt.datetime) else str(value)
