"""What goes into the history's rows: read from a record (``ogacq-record/1``,
docs/calibration-record.md section 5) and from a write-back's audit.

Pure functions and plain data: the store writes what these return, the tests
check them without a database.
"""

from __future__ import annotations

import hashlib
import math
import time
from collections.abc import Mapping
from dataclasses import dataclass
from datetime import datetime
from typing import Any

from ogacq.model.gauges import AXES
from ogacq.model.instrument import finite_number as _number

RECORD_FORMAT = "ogacq-record/1"


class RecordError(ValueError):
    """A record that is not an ``ogacq-record/1`` document the history can hold."""


@dataclass(frozen=True)
class Parameter:
    name: str  # "joint_offset.x"
    value_mm: float
    u_mm: float | None  # standard uncertainty (JCGM 100:2008 2.3.4: u_c)
    expanded_mm: float | None  # U = k u_c (JCGM 100:2008 6.2.1)
    k: float | None
    std_mm: float | None = None  # the fit's standard deviation (type A, JCGM 100:2008 4.2)


@dataclass(frozen=True)
class WriteBack:
    """One write-back or restore as the session's audit records tell it (the fields of
    ``ogacq.writeback.audit.Operation``, which sits above this package)."""

    operation: str
    action: str  # write, restore
    status: str  # done, failed, interrupted
    old_mm: Mapping[str, float]
    new_mm: Mapping[str, float]  # as read back when done, else as intended
    profile: str | None
    wall: float | None
    restores: str | None = None  # what a restore put back (an operation or a state)

    @property
    def kind(self) -> str:
        return "restore" if self.action == "restore" else "write-back"


@dataclass(frozen=True)
class MapsWriteBack:
    """One maps write or restore as the session's audit tells it (the fields of
    ``ogacq.writeback.maps.MapsOperation``, the maps as their JSON)."""

    operation: str
    action: str  # write, restore
    status: str  # done, failed, interrupted
    maps_file: str
    old_maps: tuple[Mapping[str, Any], ...]  # ogacq-axis-map/1 each
    old_checksum: str
    new_maps: tuple[Mapping[str, Any], ...]
    new_checksum: str  # as read back when done, else as intended
    wall: float | None
    restores: str | None = None

    @property
    def kind(self) -> str:
        return "map-restore" if self.action == "restore" else "map-write"


def clean_json(value: Any) -> Any:
    """``value`` with every non-finite float as None: JSON has no NaN, and
    PostgreSQL's json type refuses it."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, Mapping):
        return {str(k): clean_json(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [clean_json(v) for v in value]
    return value


def check_record(record: Any) -> dict[str, Any]:
    """The record, checked for what the history reads from it; RecordError naming
    what is missing."""
    if not isinstance(record, Mapping):
        raise RecordError("a record is a JSON object")
    if record.get("format") != RECORD_FORMAT:
        raise RecordError(f"not an {RECORD_FORMAT} record (format {record.get('format')!r})")
    if not isinstance(record.get("id"), str) or not record["id"]:
        raise RecordError("the record has no id")
    machine = record.get("machine")
    if not isinstance(machine, Mapping) or not isinstance(machine.get("name"), str) \
            or not machine["name"].strip():
        raise RecordError(f"record {record['id']} names no machine")
    return dict(record)


def machine_of(record: Mapping[str, Any]) -> tuple[str, str]:
    """(name, serial) of the record's machine; the serial is "" when none is given."""
    machine = record["machine"]
    return machine["name"].strip(), str(machine.get("serial") or "").strip()


def parameters_of(record: Mapping[str, Any]) -> list[Parameter]:
    """Every identified parameter of ``results`` (``{"joint_offset": {"x": {...}}}``),
    by its dotted name, in the record's order."""
    out = []
    for group, entries in (record.get("results") or {}).items():
        if not isinstance(entries, Mapping):
            continue
        for where, entry in entries.items():
            if not isinstance(entry, Mapping) or _number(entry.get("value_mm")) is None:
                continue
            out.append(Parameter(f"{group}.{where}", float(entry["value_mm"]),
                                 _number(entry.get("u_mm")), _number(entry.get("U_mm")),
                                 _number(entry.get("k")), _number(entry.get("std_mm"))))
    return out


def ambient_of(record: Mapping[str, Any]) -> float | None:
    """The ambient temperature at the start (else at the end) of the campaign, degC."""
    environment = record.get("environment") or {}
    for stage in ("start", "end"):
        entry = environment.get(stage) if isinstance(environment, Mapping) else None
        if isinstance(entry, Mapping) and _number(entry.get("ambient_c")) is not None:
            return float(entry["ambient_c"])
    return None


def acceptance_decision(record: Mapping[str, Any]) -> str | None:
    acceptance = record.get("acceptance")
    if not isinstance(acceptance, Mapping):
        return None
    as_found = acceptance.get("as_found")
    return str(as_found.get("decision")) if isinstance(as_found, Mapping) \
        and as_found.get("decision") is not None else None


def event_key(kind: str, record_id: str, operation: str | None = None) -> str:
    """One key per thing recorded: a calibration or diagnosis per record, a
    write-back or restore per audited operation."""
    return f"{kind}:{record_id}" + (f":{operation}" if operation else "")


def record_columns(record: Mapping[str, Any]) -> dict[str, Any]:
    """The event columns a record fills (every kind of event carries its record's)."""
    session = found if isinstance(found := record.get("session"), Mapping) else {}
    method = stated if isinstance(stated := record.get("method"), Mapping) else {}
    return {
        "record_id": record["id"],
        "campaign_date": str(record["date"]) if record.get("date") else None,
        "operator": str(record["operator"]) if record.get("operator") else None,
        "software": str(method.get("software")) if method.get("software") else None,
        "session_path": str(session.get("path")) if session.get("path") else None,
        "session_sha256": str(session.get("sha256")) if session.get("sha256") else None,
        "verdict": clean_json(record.get("verdict")),
        "acceptance_decision": acceptance_decision(record),
        "acceptance": clean_json(record.get("acceptance")),
        "instruments": clean_json(record.get("instruments")),
        "environment": clean_json(record.get("environment")),
        "ambient_c": ambient_of(record),
        "overrides": clean_json(record.get("overrides")),
    }


def local_iso(wall: float | None) -> str | None:
    """A Unix time as a local ISO 8601 date and time with its UTC offset."""
    if wall is None:
        return None
    return datetime.fromtimestamp(wall).astimezone().isoformat(timespec="seconds")


def utc_now() -> str:
    return time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())


def state_id(machine: tuple[str, str], operation: str, stage: str) -> str:
    """A short, stable id of an offsets state: the same write-back recorded by two
    stations gets the same id, two write-backs never share one."""
    digest = hashlib.sha256("\0".join((*machine, operation, stage)).encode("utf-8"))
    return f"S-{digest.hexdigest()[:10]}"


def map_state_id(machine: tuple[str, str], operation: str, stage: str) -> str:
    """As ``state_id``, for a maps state (``M-``)."""
    digest = hashlib.sha256("\0".join((*machine, "maps", operation, stage)).encode("utf-8"))
    return f"M-{digest.hexdigest()[:10]}"


def offsets_row(values: Mapping[str, float] | None) -> dict[str, float | None]:
    values = values or {}
    return {f"{a}_mm": _number(values.get(a)) for a in AXES}
