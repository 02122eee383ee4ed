"""What goes into the history's rows: read from a record (``ogacq-record/1``,
docs/calibration-record.md section 5) and from a write-back's audit; and what the
store reads back (machines, calibrations, events, states).

Pure functions and plain data, without SQLAlchemy: the store writes what these
return, the tests check them without a database, and a command imports them without
the database layer.
"""

from __future__ import annotations

import hashlib
import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from datetime import datetime
from typing import TYPE_CHECKING, Any

from ogacq.errors import InputError
from ogacq.model.gauges import AXES
from ogacq.model.instrument import finite_number as _number
from ogacq.model.parameters import EFFECT_BY_NAME

if TYPE_CHECKING:  # the record's types are read when a record is: not to find one there
    from ogacq.record.calibration_record import CalibrationRecord
    from ogacq.record.sections import NamedResult

RECORD_FORMAT = "ogacq-record/1"


class RecordError(InputError, ValueError):
    """A record that is not an ``ogacq-record/1`` document the history can hold (a
    ValueError as well, as its callers took it before it joined the root)."""

    def __init__(self, problem: str) -> None:
        super().__init__(None, problem)


@dataclass(frozen=True)
class Parameter:
    name: str  # "joint_offset.x"
    value_mm: float
    u_mm: float | None  # standard uncertainty (JCGM 100:2008 2.3.4: u_c)
    expanded_mm: float | None  # U = k u_c (JCGM 100:2008 6.2.1)
    k: float | None
    std_mm: float | None = None  # the fit's standard deviation (type A, JCGM 100:2008 4.2)


def parameter_unit(name: str) -> str:
    """The unit a parameter is stated in, in the history's table and its figure alike:
    its effect's (``EffectKind.unit``: mm for a length), mm for a name this version
    does not know (the history holds lengths in mm)."""
    effect = EFFECT_BY_NAME.get(name.partition(".")[0])
    return effect.unit if effect is not None else "mm"


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


# --- what the history holds, read back (History.machines, calibrations, states, ...)

@dataclass(frozen=True)
class Machine:
    id: int
    name: str
    serial: str

    def describe(self) -> str:
        return f"{self.name} (serial {self.serial})" if self.serial else self.name

    @property
    def label(self) -> str:
        """How a person names this machine and no other of the same name: what
        ``find_machine`` takes back."""
        return self.describe() if self.serial else f"{self.name} (no serial)"


@dataclass(frozen=True)
class Calibration:
    record_id: str
    date: str | None
    operator: str | None
    verdict: dict[str, Any] | None
    acceptance_decision: str | None
    acceptance: dict[str, Any] | None
    ambient_c: float | None
    parameters: dict[str, Parameter]
    session_path: str | None
    session_sha256: str | None
    instruments: list[Any] | None = None
    environment: dict[str, Any] | None = None
    overrides: list[Any] | None = None
    station: str | None = None
    simulated: bool | None = None  # a rehearsal on the simulator (None: not said)
    # the joint offsets the controller held during the campaign, the same at every start
    # (None: the record does not say, or they changed between starts)
    offsets_in_force_mm: dict[str, float] | None = None


@dataclass(frozen=True)
class Event:
    kind: str
    record_id: str
    date: str | None
    operator: str | None
    session_path: str | None
    details: dict[str, Any] | None


@dataclass(frozen=True)
class State:
    """What an offsets state and a maps state both say: the write or restore that found
    (``before``) or left (``after``) it."""

    state_id: str
    stage: str  # before, after
    at: str | None
    wall: float | None
    operation: str
    action: str
    status: str

    def _as_mapping(self, own: dict[str, Any], record_id: str,
                    session_path: str | None) -> dict[str, Any]:
        return {"state": self.state_id, "stage": self.stage, "at": self.at,
                "operation": self.operation, "action": self.action, "status": self.status,
                **own, "record": record_id, "session": session_path}


@dataclass(frozen=True)
class OffsetState(State):
    profile: str | None
    offsets_mm: dict[str, float | None]
    record_id: str
    session_path: str | None

    def as_mapping(self) -> dict[str, Any]:
        return self._as_mapping({"profile": self.profile, "offsets_mm": self.offsets_mm},
                                self.record_id, self.session_path)


@dataclass(frozen=True)
class MapState(State):
    maps_file: str | None
    checksum: str | None
    maps: list[dict[str, Any]]  # ogacq-axis-map/1 each
    record_id: str
    session_path: str | None

    def as_mapping(self) -> dict[str, Any]:
        return self._as_mapping({"maps_file": self.maps_file, "checksum": self.checksum,
                                 "axes": [m.get("axis") for m in self.maps]},
                                self.record_id, self.session_path)


@dataclass
class Recorded:
    """What one call recorded: the keys written, and those already there."""

    new: list[str] = field(default_factory=list)
    present: list[str] = field(default_factory=list)

    def __iadd__(self, other: Recorded) -> Recorded:
        self.new += other.new
        self.present += other.present
        return self


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
    what is missing, RecordSectionError the key of a section of another shape."""
    if not isinstance(record, Mapping):
        raise RecordError("a record is a JSON object")
    typed = typed_record(record)
    if typed.format != RECORD_FORMAT:
        raise RecordError(f"not an {RECORD_FORMAT} record (format {typed.as_written('format')!r})")
    if not typed.id:
        raise RecordError("the record has no id")
    name = typed.machine_section.name
    if name is None or not name.strip():
        raise RecordError(f"record {typed.id} names no machine")
    # every section the history reads: one of another shape said before anything is written
    _ = record_columns(typed), parameters_of(typed), typed.offsets_in_force_mm
    return dict(record)


def typed_record(record: Mapping[str, Any] | CalibrationRecord) -> CalibrationRecord:
    """A record read as ``CalibrationRecord`` (its module imported only when a record is
    read: a diagnosis the history holds already reads none)."""
    from ogacq.record.calibration_record import CalibrationRecord

    return record if isinstance(record, CalibrationRecord) else CalibrationRecord.from_json(record)


def machine_of(record: Mapping[str, Any] | CalibrationRecord) -> tuple[str, str]:
    """(name, serial) of the record's machine (checked by ``check_record``); the serial
    is "" when none is given."""
    machine = typed_record(record).machine_section
    return str(machine.name).strip(), (machine.serial or "").strip()


def parameters_in(entries: Sequence[NamedResult]) -> list[Parameter]:
    """The parameters of a record's (or a history entry's) ``results`` that have a value."""
    return [Parameter(n.name, e.value_mm, e.u_mm, e.U_mm, e.k, e.std_mm)
            for n in entries if (e := n.entry).value_mm is not None]


def parameters_of(record: Mapping[str, Any] | CalibrationRecord) -> list[Parameter]:
    """Every identified parameter of ``results`` (``{"joint_offset": {"x": {...}}}``),
    by its dotted name, in the record's order."""
    return parameters_in(typed_record(record).result_entries)


def ambient_of(record: Mapping[str, Any] | CalibrationRecord) -> float | None:
    """The ambient temperature at the start (else at the end) of the campaign, degC."""
    stages = typed_record(record).environment_stages
    return next((float(t.ambient_c) for stage in ("start", "end") if stage in stages
                 and (t := stages[stage]) is not None and t.ambient_c is not None), None)


def acceptance_decision(record: Mapping[str, Any] | CalibrationRecord) -> str | None:
    """The as-found decision (pass, fail, undecided), None when not recorded."""
    return typed_record(record).acceptance_section.as_found.decision


def event_key(kind: str, record_id: str, operation: str | None = None) -> str:
    """One key per thing recorded: a calibration or diagnosis per record, a
    write-back or restore per audited operation."""
    return f"{kind}:{record_id}" + (f":{operation}" if operation else "")


def record_columns(record: Mapping[str, Any] | CalibrationRecord) -> dict[str, Any]:
    """The event columns a record fills (every kind of event carries its record's)."""
    typed = typed_record(record)
    session = typed.session_file
    return {
        "record_id": typed.id,
        "campaign_date": typed.date or None,
        "operator": typed.operator or None,
        "software": typed.method_section.software or None,
        "session_path": session.path or None,
        "session_sha256": session.sha256 or None,
        "verdict": clean_json(typed.as_written("verdict")),
        "acceptance_decision": acceptance_decision(typed),
        "acceptance": clean_json(typed.as_written("acceptance")),
        "instruments": clean_json(typed.as_written("instruments")),
        "environment": clean_json(typed.as_written("environment")),
        "ambient_c": ambient_of(typed),
        "overrides": clean_json(typed.as_written("overrides")),
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
