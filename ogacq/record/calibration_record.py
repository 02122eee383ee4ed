"""The calibration record (``ogacq-record/1``, docs/calibration-record.md section 5) as
one typed value for those who read it: the report, the history, the console.

It is built as JSON by ``ogacq.record.document.build_record`` and kept so
(``record.json``, the history's rows); ``from_json`` then ``to_json`` gives back the
same keys in the same order with the same values, so the document, its SHA-256 and
its revisions (``ogacq.record.revision``) do not depend on this type. The sections
read by more than one module are named; every other key, and a named one of another
type than this version writes (a hand-edited file), is kept in ``extra`` where it was
(the named attribute then None, as for a key the record does not have).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

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
    simulated: bool | None = None
    campaign: JsonObject | None = None  # status, readings, planned, reason, partial
    results: JsonObject | None = None  # effect -> where -> value, U, std, ...
    validation_results: JsonObject | None = None  # the same, of the as-left campaign
    history: Sequence[Any] | None = None  # earlier calibrations: id, date, results
    session: JsonObject | None = None  # path, sha256, records, integrity, edited
    missing: JsonObject | None = None  # what the record lacks, and why
    revision: int | None = None  # 1 for the first issue
    # each named key and the JSON type this version writes it as (dict: an object)
    NAMED: ClassVar[Mapping[str, type]] = {
        "format": str, "id": str, "issued": str, "machine": dict, "operator": str,
        "date": str, "simulated": bool, "campaign": dict, "results": dict,
        "validation_results": dict, "history": list, "session": dict, "missing": dict,
        "revision": int}
    # every other key, and a named one of an unexpected type, as written
    extra: JsonObject = field(default_factory=dict)
    # the keys in the order written (empty: the named attributes given, then extra)
    order: tuple[str, ...] = ()


CalibrationRecord.check_named()
