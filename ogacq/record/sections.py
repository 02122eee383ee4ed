"""The sections of a calibration record whose inner keys more than one module reads
(docs/calibration-record.md section 5), each a small typed value read from the JSON.

Each ``from_json`` is as tolerant as the readers were when they read the dicts by
hand: a value of another type than the record writes (a hand-edited or older
record) reads as None, an entry that is not an object is skipped, and ``fields``
keeps the section as written for those who show every key (the page).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from ogacq.model.instrument import finite_number
from ogacq.session.json_document import JsonObject

__all__ = ["Acceptance", "AcceptanceStage", "HistoryEntry", "RecordMachine", "ResultEntry",
           "SessionReference", "Verdict", "result_entries"]


def _object(value: Any) -> JsonObject:
    """``value`` when it is a JSON object, else an empty one."""
    return value if isinstance(value, Mapping) else {}


def _text(value: Any) -> str | None:
    """A value as text, None when absent or null."""
    return None if value is None else str(value)


@dataclass(frozen=True)
class RecordMachine:
    """``machine``: the name and serial number the record names, the machine file."""

    name: str | None  # None when not a string (check_record refuses such a record)
    serial: str | None
    file: Any  # the machine file as recorded (an object, or null)

    @classmethod
    def from_json(cls, machine: Any) -> RecordMachine:
        found = _object(machine)
        name = found.get("name")
        return cls(name if isinstance(name, str) else None, _text(found.get("serial")),
                   found.get("file"))


@dataclass(frozen=True)
class SessionReference:
    """``session`` / ``validation_session``: the session file the record was built from."""

    path: str | None
    sha256: str | None
    records: int | None
    fields: JsonObject = field(default_factory=dict)  # as written (integrity, edited)

    @classmethod
    def from_json(cls, session: Any) -> SessionReference:
        found = _object(session)
        records = found.get("records")
        return cls(_text(found.get("path")), _text(found.get("sha256")),
                   records if isinstance(records, int) and not isinstance(records, bool)
                   else None, found)


@dataclass(frozen=True)
class ResultEntry:
    """One parameter of ``results`` (or ``validation_results``): its value and
    uncertainties in mm, each None when the record does not hold a finite number."""

    name: str  # "joint_offset.x"
    value_mm: float | None
    u_mm: float | None  # standard uncertainty u_c (JCGM 100:2008 2.3.4)
    U_mm: float | None  # expanded, U = k u_c (JCGM 100:2008 6.2.1)
    k: float | None
    std_mm: float | None  # the fit's standard deviation alone (type A)
    dof_eff: float | None  # null in the record: infinite (JCGM 100:2008 G.4.2)
    fields: JsonObject = field(default_factory=dict)  # every key as written

    @classmethod
    def from_json(cls, name: str, entry: JsonObject) -> ResultEntry:
        return cls(name, finite_number(entry.get("value_mm")),
                   finite_number(entry.get("u_mm")), finite_number(entry.get("U_mm")),
                   finite_number(entry.get("k")), finite_number(entry.get("std_mm")),
                   finite_number(entry.get("dof_eff")), entry)


def result_entries(results: Any) -> tuple[ResultEntry, ...]:
    """Every entry of a ``results`` object (``{"joint_offset": {"x": {...}}}``), by its
    dotted name in the record's order; a group or entry that is not an object skipped."""
    return tuple(ResultEntry.from_json(f"{group}.{where}", entry)
                 for group, entries in _object(results).items()
                 for where, entry in _object(entries).items() if isinstance(entry, Mapping))


@dataclass(frozen=True)
class Verdict:
    """``verdict``: whether the fit is consistent with the gauge noise, and its p."""

    state: str | None
    consistent: bool | None
    p: float | None  # the combined p (p_combined)
    chi2_dof: float | None
    text: str | None
    fields: JsonObject = field(default_factory=dict)  # every key as written

    @classmethod
    def from_json(cls, verdict: Any) -> Verdict:
        found = _object(verdict)
        consistent = found.get("consistent")
        return cls(_text(found.get("state")),
                   consistent if isinstance(consistent, bool) else None,
                   finite_number(found.get("p")), finite_number(found.get("chi2_dof")),
                   _text(found.get("text")), found)


@dataclass(frozen=True)
class AcceptanceStage:
    """``acceptance.as_found`` or ``as_left``: the decision, why, and one row per
    deviation (ISO 14253-1 style decision rule)."""

    decision: str | None  # pass, fail, undecided, not evaluated
    why: str | None
    rows: tuple[JsonObject, ...]
    others: JsonObject  # every other key (the rule, ...)

    @classmethod
    def from_json(cls, stage: Any) -> AcceptanceStage:
        found = _object(stage)
        rows = found.get("rows")
        return cls(_text(found.get("decision")), _text(found.get("why")),
                   tuple(r for r in rows if isinstance(r, Mapping))
                   if isinstance(rows, list) else (),
                   {k: v for k, v in found.items() if k not in ("decision", "why", "rows")})


@dataclass(frozen=True)
class Acceptance:
    """``acceptance``: the decision rule, and its stages before and after a write-back."""

    rule: Any
    as_found: AcceptanceStage
    as_left: AcceptanceStage

    @classmethod
    def from_json(cls, acceptance: Any) -> Acceptance:
        found = _object(acceptance)
        return cls(found.get("rule"), AcceptanceStage.from_json(found.get("as_found")),
                   AcceptanceStage.from_json(found.get("as_left")))


@dataclass(frozen=True)
class HistoryEntry:
    """One earlier calibration of ``history`` (``{"id", "date", "results"}``), or the
    record itself seen as one."""

    id: str | None
    date: str | None
    results: tuple[ResultEntry, ...]

    @classmethod
    def from_json(cls, entry: JsonObject) -> HistoryEntry:
        return cls(_text(entry.get("id")), _text(entry.get("date")),
                   result_entries(entry.get("results")))

    @classmethod
    def all_of(cls, history: Sequence[Any] | None) -> tuple[HistoryEntry, ...]:
        """The entries of a ``history`` list that are objects, in order."""
        return tuple(cls.from_json(e) for e in history or () if isinstance(e, Mapping))
