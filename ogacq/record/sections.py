"""The record's inner sections (docs/calibration-record.md section 5), declared once
(``ogacq.record.declared``); ``compensation`` has its own module. Built as JSON by
``ogacq.record.document``; a key each declares is read typed, the others kept as
written, for the page that shows every key.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from ogacq.record.declared import Section

__all__ = ["Acceptance", "AcceptanceStage", "BudgetRow", "CampaignSection", "EditedRecord",
           "HistoryEntry", "InstrumentEntry", "MethodSection", "NamedResult", "OverrideEntry",
           "RecordMachine", "ResultEntry", "Revises", "SessionFile", "Temperatures", "Verdict",
           "WriteBackEntry", "named_results"]


@dataclass(frozen=True)
class RecordMachine(Section):
    """``machine``: the name and serial number the record names, the machine file."""

    name: str | None = None
    serial: str | None = None
    file: Any = None  # the machine file as recorded (an object, or null)


@dataclass(frozen=True)
class CampaignSection(Section):
    """``campaign``: how the campaign ended, its readings, and why it did not finish."""

    status: str | None = None  # complete, stopped, incomplete
    readings: int | None = None
    planned: int | None = None
    reason: str | None = None
    partial: str | None = None  # what the campaign did not do (None: finished)


@dataclass(frozen=True)
class Revises(Section):
    """``revises``: the issue a revision replaces (ISO/IEC 17025:2017 7.8.8)."""

    revision: int | None = None
    issued: str | None = None
    sha256: str | None = None  # of its record.json


@dataclass(frozen=True)
class EditedRecord(Section):
    """One of ``session.edited``: a record the user accepted as it stands."""

    line: int | None = None
    problem: str | None = None


@dataclass(frozen=True)
class SessionFile(Section):
    """``session`` / ``validation_session``: the session file, how it vouches for its
    records (``ogacq.session.seal``) and the records accepted as edited."""

    path: str | None = None
    sha256: str | None = None
    records: int | None = None
    integrity: str | None = None  # sealed or unchecked
    edited: tuple[EditedRecord, ...] = ()


@dataclass(frozen=True)
class InstrumentEntry(Section):
    """One of ``instruments`` (``Instrument.to_json`` and whether it had expired); its
    make, model, certificate, ... kept as written, for the page that shows each."""

    gauge: str | None = None
    expired: bool | None = None  # None: its due date unknown


@dataclass(frozen=True)
class Temperatures(Section):
    """``environment.start`` / ``end`` (``Temperatures.to_json``), in °C."""

    ambient_c: float | None = None
    machine_c: float | None = None
    source: str | None = None


@dataclass(frozen=True)
class OverrideEntry(Section):
    """One of ``overrides`` (``Override.to_json``): what was accepted, of which subject
    (an expired gauge: ``"x ..."``), until when, why, by whom."""

    what: str | None = None
    subject: str | None = None


@dataclass(frozen=True)
class WriteBackEntry(Section):
    """One of ``writeback``: a write of the joint offsets during the campaign."""

    action: str | None = None
    status: str | None = None  # done, failed, ...
    when: str | None = None
    old_mm: dict[str, float | None] = field(default_factory=dict)
    new_mm: dict[str, float | None] = field(default_factory=dict)
    details: Any = None


@dataclass(frozen=True)
class MethodSection(Section):
    """``method``: the protocol, the parameters, how they were identified, the software,
    the decision rule and the joint offsets in force during the campaign."""

    protocol: Any = None  # the session's plan (an object) or its name
    params: Any = None
    identification: Any = None  # method, weighting, readings, noise (None: no fit)
    software: str | None = None
    record_software: str | None = None
    decision_rule: Any = None
    offsets_in_force_mm: dict[str, float | None] | None = None  # absent: not recorded
    offsets_in_force_consistent: bool | None = None


@dataclass(frozen=True)
class BudgetRow(Section):
    """One contribution of ``budget.<parameter>`` (source, type, ..., u_mm)."""

    u_mm: float | None = None


@dataclass(frozen=True)
class ResultEntry(Section):
    """One parameter of ``results`` (or ``validation_results``), in mm; None where the
    record holds none (null: JSON has no NaN)."""

    value_mm: float | None = None
    u_mm: float | None = None  # standard uncertainty u_c (JCGM 100:2008 2.3.4)
    U_mm: float | None = None  # expanded, U = k u_c (JCGM 100:2008 6.2.1)
    k: float | None = None
    std_mm: float | None = None  # the fit's standard deviation alone (type A)
    dof_eff: float | None = None  # null: infinite (JCGM 100:2008 G.4.2)
    complete: bool | None = None  # whether the budget behind u is
    unit: str | None = None


Results = dict[str, dict[str, ResultEntry]]  # effect -> where -> entry


@dataclass(frozen=True)
class NamedResult:
    """A result entry with its dotted name (``joint_offset.x``)."""

    name: str
    entry: ResultEntry


def named_results(results: Results) -> tuple[NamedResult, ...]:
    """Every entry of a ``results`` object by its dotted name, in the record's order."""
    return tuple(NamedResult(f"{group}.{where}", entry)
                 for group, entries in results.items() for where, entry in entries.items())


@dataclass(frozen=True)
class Verdict(Section):
    """``verdict``: whether the fit is consistent with the gauge noise, and its p."""

    state: str | None = None
    consistent: bool | None = None
    p: float | None = None  # the combined p (p_combined)
    chi2_dof: float | None = None
    text: str | None = None


@dataclass(frozen=True)
class AcceptanceStage(Section):
    """``acceptance.as_found`` or ``as_left``: the decision, why, and one row per
    deviation (ISO 14253-1 style decision rule); the rule and others in ``extra``."""

    decision: str | None = None  # pass, fail, undecided, not evaluated
    why: str | None = None
    rows: tuple[dict[str, Any], ...] = ()


@dataclass(frozen=True)
class Acceptance(Section):
    """``acceptance``: the decision rule, and its stages before and after a write-back."""

    rule: Any = None
    as_found: AcceptanceStage = field(default_factory=AcceptanceStage)
    as_left: AcceptanceStage = field(default_factory=AcceptanceStage)


@dataclass(frozen=True)
class HistoryEntry(Section):
    """One earlier calibration of ``history``, or the record itself seen as one."""

    id: str | None = None
    date: str | None = None
    results: Results = field(default_factory=dict)
