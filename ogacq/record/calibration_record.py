"""The calibration record (``ogacq-record/1``, docs/calibration-record.md section 5) as
one typed value for those who read it: the report, the history, the console.

It is built as JSON by ``ogacq.record.document.build_record`` and kept so
(``record.json``, the history's rows); ``from_json`` then ``to_json`` gives back the
same keys in the same order with the same values, so the document, its SHA-256 and
its revisions (``ogacq.record.revision``) do not depend on this type. The sections
read by another module are named; every other key, and a named one of another type
than this version writes (a hand-edited file), is kept in ``extra`` where it was (the
named attribute then None, as for a key the record does not have). Every section is
also given typed, declared once (``ogacq.record.sections``: ``machine_section``,
``result_entries``, ``verdict_section``, ...); one of another shape is a
``RecordSectionError`` naming its key (``results.joint_offset.x.U_mm``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

from ogacq.record.axis_scales import AxisScaleEntry
from ogacq.record.compensation import CompensationSection
from ogacq.record.declared import read_as
from ogacq.record.sections import (
    Acceptance,
    BudgetRow,
    CampaignSection,
    HistoryEntry,
    InstrumentEntry,
    MethodSection,
    NamedResult,
    OverrideEntry,
    RecordMachine,
    Results,
    Revises,
    SessionFile,
    Temperatures,
    Verdict,
    WriteBackEntry,
    named_results,
)
from ogacq.session.json_document import JsonObject, NamedJson

__all__ = ["CalibrationRecord"]


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
    # each axis's positioning tests by its scale (only where scales were used); read:
    # axis_scale_entries
    axis_scales: JsonObject | None = None
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

    # --- the sections declared once (ogacq.record.sections): each None (or empty)
    # when the record does not have it, a RecordSectionError naming the key when it
    # holds something else than its declaration
    def _typed(self, hint: Any, key: str) -> Any:
        return read_as(hint, self.as_written(key), key)

    @cached_property
    def machine_section(self) -> RecordMachine:
        return self._typed(RecordMachine, "machine") or RecordMachine()

    @cached_property
    def compensation_section(self) -> CompensationSection | None:
        """What ``ogacq calibrate`` wrote beside the offsets."""
        return self._typed(CompensationSection, "compensation")

    @cached_property
    def axis_scale_entries(self) -> dict[str, AxisScaleEntry]:
        """Each axis's positioning tests by its scale (empty: no scale was used)."""
        return self._typed(dict[str, AxisScaleEntry], "axis_scales") or {}

    @cached_property
    def campaign_section(self) -> CampaignSection:
        return self._typed(CampaignSection, "campaign") or CampaignSection()

    @cached_property
    def method_section(self) -> MethodSection:
        return self._typed(MethodSection, "method") or MethodSection()

    @cached_property
    def revises_section(self) -> Revises | None:
        return self._typed(Revises, "revises")

    @cached_property
    def session_file(self) -> SessionFile:
        return self._typed(SessionFile, "session") or SessionFile()

    @cached_property
    def validation_session_file(self) -> SessionFile | None:
        return self._typed(SessionFile, "validation_session")

    @cached_property
    def verdict_section(self) -> Verdict | None:
        """The verdict, None when the record has none (no fit)."""
        return self._typed(Verdict, "verdict")

    @cached_property
    def acceptance_section(self) -> Acceptance:
        return self._typed(Acceptance, "acceptance") or Acceptance()

    @cached_property
    def environment_stages(self) -> dict[str, Temperatures | None]:
        """The temperatures at each stage (start, end); None: not recorded."""
        return self._typed(dict[str, Temperatures | None], "environment") or {}

    @cached_property
    def missing_reasons(self) -> dict[str, str]:
        """What the record lacks, and why."""
        return self._typed(dict[str, str], "missing") or {}

    @cached_property
    def result_entries(self) -> tuple[NamedResult, ...]:
        return named_results(self._typed(Results, "results") or {})

    @cached_property
    def validation_result_entries(self) -> tuple[NamedResult, ...]:
        return named_results(self._typed(Results, "validation_results") or {})

    @cached_property
    def instrument_entries(self) -> tuple[InstrumentEntry, ...]:
        return self._typed(tuple[InstrumentEntry, ...], "instruments") or ()

    @cached_property
    def override_entries(self) -> tuple[OverrideEntry, ...]:
        return self._typed(tuple[OverrideEntry, ...], "overrides") or ()

    @cached_property
    def writeback_entries(self) -> tuple[WriteBackEntry, ...]:
        return self._typed(tuple[WriteBackEntry, ...], "writeback") or ()

    @cached_property
    def history_entries(self) -> tuple[HistoryEntry, ...]:
        """The earlier calibrations the record holds, in its order."""
        return self._typed(tuple[HistoryEntry, ...], "history") or ()

    @cached_property
    def budget_rows(self) -> dict[str, tuple[BudgetRow, ...]]:
        """Each parameter's contributions, in the record's order."""
        return self._typed(dict[str, tuple[BudgetRow, ...]], "budget") or {}

    @property
    def offsets_in_force_mm(self) -> dict[str, float] | None:
        """The controller's joint offsets during the campaign (``method``), the same at
        every start; None when not recorded, changed between starts, or not numbers."""
        method = self.method_section
        found = method.offsets_in_force_mm
        if method.offsets_in_force_consistent is not True or found is None \
                or any(v is None for v in found.values()):
            return None
        return {a: float(v) for a, v in found.items() if v is not None}

    def as_history_entry(self) -> HistoryEntry:
        """This calibration as a history entry (id, date, results)."""
        results = self._typed(Results, "results") or {}
        return HistoryEntry(id=self.id, date=self.date, results=results)

