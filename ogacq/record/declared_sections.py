"""The record's inner sections the page reads key by key (docs/calibration-record.md
section 5), declared once (``ogacq.record.declared``); ``compensation`` has its own
module. Built as JSON by ``ogacq.record.document``; a key each declares is read typed,
the others kept as written, for the page that shows every key.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from ogacq.record.declared import Section

__all__ = ["BudgetRow", "CampaignSection", "EditedRecord", "InstrumentEntry", "MethodSection",
           "OverrideEntry", "Revises", "SessionFile", "WriteBackEntry"]


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
    integrity: str | None = None  # sealed or unchecked (absent: before them)
    edited: tuple[EditedRecord, ...] = ()


@dataclass(frozen=True)
class InstrumentEntry(Section):
    """One of ``instruments`` (``Instrument.to_json`` and whether it had expired); its
    make, model, certificate, ... kept as written, for the page that shows each."""

    gauge: str | None = None
    expired: bool | None = None  # None: its due date unknown


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
    offsets_in_force_mm: Any = None  # axis -> mm; absent: not recorded
    offsets_in_force_consistent: bool | None = None


@dataclass(frozen=True)
class BudgetRow(Section):
    """One contribution of ``budget.<parameter>`` (source, type, ..., u_mm)."""

    u_mm: float | None = None
