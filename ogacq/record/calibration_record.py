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
from dataclasses import dataclass, field, fields
from typing import Any

__all__ = ["CalibrationRecord"]

JsonObject = Mapping[str, Any]


@dataclass(frozen=True)
class CalibrationRecord:
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
    # every other key, and a named one of an unexpected type, as written
    extra: JsonObject = field(default_factory=dict)
    # the keys in the order written (empty: the named attributes given, then extra)
    order: tuple[str, ...] = ()

    @classmethod
    def from_json(cls, document: JsonObject) -> CalibrationRecord:
        """The record a ``record.json`` document (a JSON object) says."""
        named: dict[str, Any] = {}
        extra: dict[str, Any] = {}
        for key, value in document.items():
            expected = _NAMED.get(key)
            if expected is not None and (value is None or _is(value, expected)):
                named[key] = value
            else:
                extra[key] = value
        return cls(**named, extra=extra, order=tuple(document))

    def to_json(self) -> dict[str, Any]:
        """The record as a JSON object, exactly as it was read."""
        keys = self.order or (*(name for name in _NAMED if getattr(self, name) is not None),
                              *self.extra)
        return {key: self.extra[key] if key in self.extra else getattr(self, key)
                for key in keys}

    def __contains__(self, key: str) -> bool:
        """Whether the record has ``key`` at all (null included)."""
        return key in (self.order or self.to_json())


def _is(value: Any, expected: type) -> bool:
    if expected is dict:
        return isinstance(value, Mapping)
    return isinstance(value, expected) and (expected is bool or not isinstance(value, bool))


# each named key and the JSON type this version writes it as (dict: an object)
_NAMED: dict[str, type] = {
    "format": str, "id": str, "issued": str, "machine": dict, "operator": str, "date": str,
    "simulated": bool, "campaign": dict, "results": dict, "validation_results": dict,
    "history": list, "session": dict, "missing": dict, "revision": int}
assert set(_NAMED) == {f.name for f in fields(CalibrationRecord)} - {"extra", "order"}
