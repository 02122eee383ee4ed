"""The calibration record (``ogacq-record/1``, docs/calibration-record.md section 5) as
one typed value for those who read it: the report, the history, the console.

It is built as JSON by ``ogacq.record.document.build_record`` and kept so
(``record.json``, the history's rows); ``from_json`` then ``to_json`` gives back the
same keys in the same order with the same values, so the document, its SHA-256 and
its revisions (``ogacq.record.revision``) do not depend on this type. The sections
read by another module are named; every other key, and a named one of another type
than this version writes (a hand-edited file), is kept in ``extra`` where it was (the
named attribute then None, as for a key the record does not have). A section whose
inner keys more than one module reads is also given as a typed value
(``ogacq.record.sections``: ``machine_named``, ``result_entries``, ``verdict_read``,
...), read from the JSON as tolerantly as the readers did by hand.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, TypeVar

from ogacq.record.compensation import CompensationSection
from ogacq.record.declared import Section, read, read_all, read_lists
from ogacq.record.declared_sections import (
    BudgetRow,
    CampaignSection,
    InstrumentEntry,
    MethodSection,
    OverrideEntry,
    Revises,
    SessionFile,
    WriteBackEntry,
)
from ogacq.record.sections import (
    Acceptance,
    HistoryEntry,
    RecordMachine,
    ResultEntry,
    SessionReference,
    Verdict,
    result_entries,
)
from ogacq.session.json_document import JsonObject, NamedJson

__all__ = ["CalibrationRecord"]

S = TypeVar("S", bound=Section)


@dataclass(frozen=True)
class CalibrationRecord(NamedJson):
    """A calibration record; None for a section it does not have (a record built
    without a fit has no ``results``, one never issued again no ``revision``)."""

    format: str | None = None  # "ogacq-record/1"
    id: str | None = None  # OGQ-YYYYMMDD-xxxxxxxx (the session's own)
    issued: str | None = None  # the issue time, ISO 8601 with offset
    machine: JsonObject | None = None  # name, serial, the machine file as recorded
    operator: str | None = None
    date: str | None = None  # the campaign's date
    date_simulated: bool | None = None  # a rehearsed simulator date
    simulated: bool | None = None
    instruments: Sequence[Any] | None = None  # gauge, make, ..., due, expired
    environment: JsonObject | None = None  # stage -> ambient_c, machine_c, source
    campaign: JsonObject | None = None  # status, readings, planned, reason, partial
    method: JsonObject | None = None  # protocol, params, identification, software, ...
    results: JsonObject | None = None  # effect -> where -> value, U, std, ...
    budget: JsonObject | None = None  # parameter -> [contribution, ...]
    budget_complete: bool | None = None
    monte_carlo: JsonObject | None = None  # draws, seed, u_mm, ratio, ...
    acceptance: JsonObject | None = None  # rule, as_found, as_left
    verdict: JsonObject | None = None  # state, consistent, chi2_dof, p, ...
    overrides: Sequence[Any] | None = None  # what, subject, due, reason, operator
    writeback: Sequence[Any] | None = None  # action, status, when, old_mm, new_mm, details
    history: Sequence[Any] | None = None  # earlier calibrations: id, date, results
    session: JsonObject | None = None  # path, sha256, records, integrity, edited
    validation_session: JsonObject | None = None  # the same, of the as-left campaign
    validation_results: JsonObject | None = None  # as results, of the as-left campaign
    compensation: JsonObject | None = None  # as written; read: compensation_section
    missing: JsonObject | None = None  # what the record lacks, and why
    revision: int | None = None  # 1 for the first issue
    revises: JsonObject | None = None  # from revision 2: revision, issued, sha256
    changes: Sequence[Any] | None = None  # what differs from the issue it revises
    # every other key, and a named one of an unexpected type, as written
    extra: JsonObject = field(default_factory=dict)
    # the keys in the order written (empty: the named attributes given, then extra)
    order: tuple[str, ...] = ()

    def as_written(self, key: str) -> Any:
        """A top-level value as the file has it, of whatever type (None when absent):
        for those who keep a section as recorded, or name a wrong value in an error."""
        return self.extra[key] if key in self.extra else getattr(self, key, None)

    # --- the sections as typed values ---------------------------------------------
    @property
    def machine_named(self) -> RecordMachine:
        return RecordMachine.from_json(self.machine)

    @property
    def session_reference(self) -> SessionReference:
        return SessionReference.from_json(self.session)

    @property
    def validation_reference(self) -> SessionReference | None:
        """The as-left session, None when the record has none."""
        return SessionReference.from_json(self.validation_session) \
            if self.validation_session else None

    @property
    def result_entries(self) -> tuple[ResultEntry, ...]:
        return result_entries(self.results)

    @property
    def validation_result_entries(self) -> tuple[ResultEntry, ...]:
        return result_entries(self.validation_results)

    @property
    def verdict_read(self) -> Verdict | None:
        """The verdict, None when the record has none (no fit)."""
        return Verdict.from_json(self.verdict) if self.verdict else None

    @property
    def acceptance_read(self) -> Acceptance:
        return Acceptance.from_json(self.acceptance)

    # --- the sections declared once (ogacq.record.declared): each None (or empty)
    # when the record does not have it, a RecordSectionError naming the key when it
    # holds something else than its declaration
    def _section(self, cls: type[S], key: str) -> S | None:
        found = self.as_written(key)
        return None if found is None else read(cls, found, key)

    @cached_property
    def compensation_section(self) -> CompensationSection | None:
        """What ``ogacq calibrate`` wrote beside the offsets."""
        return self._section(CompensationSection, "compensation")

    @cached_property
    def campaign_section(self) -> CampaignSection:
        return self._section(CampaignSection, "campaign") or CampaignSection()

    @cached_property
    def method_section(self) -> MethodSection:
        return self._section(MethodSection, "method") or MethodSection()

    @cached_property
    def revises_section(self) -> Revises | None:
        return self._section(Revises, "revises")

    @cached_property
    def session_file(self) -> SessionFile:
        return self._section(SessionFile, "session") or SessionFile()

    @cached_property
    def validation_session_file(self) -> SessionFile | None:
        return self._section(SessionFile, "validation_session")

    @cached_property
    def instrument_entries(self) -> tuple[InstrumentEntry, ...]:
        return read_all(InstrumentEntry, self.as_written("instruments"), "instruments")

    @cached_property
    def override_entries(self) -> tuple[OverrideEntry, ...]:
        return read_all(OverrideEntry, self.as_written("overrides"), "overrides")

    @cached_property
    def writeback_entries(self) -> tuple[WriteBackEntry, ...]:
        return read_all(WriteBackEntry, self.as_written("writeback"), "writeback")

    @cached_property
    def budget_rows(self) -> dict[str, tuple[BudgetRow, ...]]:
        """Each parameter's contributions, in the record's order."""
        return read_lists(BudgetRow, self.as_written("budget"), "budget")

    @property
    def history_entries(self) -> tuple[HistoryEntry, ...]:
        """The earlier calibrations the record holds, in its order."""
        return HistoryEntry.all_of(self.history)

    @property
    def offsets_in_force_mm(self) -> dict[str, float] | None:
        """The controller's joint offsets during the campaign (``method``), the same at
        every start; None when not recorded, changed between starts, or not numbers."""
        method = self.method or {}
        found = method.get("offsets_in_force_mm")
        if method.get("offsets_in_force_consistent") is not True or not isinstance(found, dict):
            return None
        if not all(isinstance(v, int | float) and not isinstance(v, bool)
                   for v in found.values()):
            return None
        return {str(a): float(v) for a, v in found.items()}

    def as_history_entry(self) -> HistoryEntry:
        """This calibration as a history entry (id, date, results)."""
        return HistoryEntry(self.id, self.date, self.result_entries)

