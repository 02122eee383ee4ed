"""The records of a session, typed and declared once: every writer builds one of
these and every reader gets one back, so a record's keys are spelled in this module
only.

On disk each record is one JSON object whose ``type`` names its class here; the
store adds ``seq``, ``prev`` and ``crc`` (``ogacq.session.seal``). A record's keys
are its fields, in their order (``wall`` after ``type``); each field's annotation
says its JSON (``ogacq.io.declared``). A field holding its default is left out,
unless :data:`ALWAYS` written or written :func:`with_` another that is.
``from_json`` refuses a value of another type, a missing key without a default and
a value a field's :func:`must` refuses, with a ``ValueError`` naming the key, which
the store reports with the line. Records of a kind this version does not know load
as :class:`OtherRecord`, untouched.
"""

from __future__ import annotations

import contextlib
import dataclasses
import typing
from collections.abc import Callable, Mapping
from dataclasses import MISSING, dataclass, field
from typing import Any, ClassVar, TypeVar

from ogacq.io.declared import Finite, Reader, checked, reader
from ogacq.model.gauges import Gauge

FORMAT = "ogacq-session/1"

Triple = tuple[Finite, Finite, Finite]
R = TypeVar("R", bound="Record")

ALWAYS = {"always": True}  # written even when it holds its default (null)


def with_(key: str) -> dict[str, str]:
    """Written whenever ``key`` is (an end's reason with whether the axes stopped)."""
    return {"with": key}


def must(test: Callable[[Any], bool], words: str) -> dict[str, Any]:
    """A value (not null) ``test`` refuses is refused, ``words`` saying what it must be."""
    return {"must": (test, words)}


def _required(f: dataclasses.Field[Any]) -> bool:
    return f.default is MISSING and f.default_factory is MISSING


# Each field of a record class as its JSON is read: key, its annotation's reader, whether
# it must be there, and its must's test and words; resolved once per class (a session's
# thousands of lines of a few kinds each read the same fields).
Plan = tuple[tuple[str, Reader, bool, Callable[[Any], bool] | None, str], ...]
_PLANS: dict[type, Plan] = {}


def _plan(cls: type[Record]) -> Plan:
    if cls not in _PLANS:
        hints = typing.get_type_hints(cls, include_extras=True)
        _PLANS[cls] = tuple((f.name, reader(hints[f.name]), _required(f),
                             *f.metadata.get("must", (None, "")))
                            for f in dataclasses.fields(cls))
    return _PLANS[cls]


@dataclass(frozen=True, kw_only=True)
class Record:
    """What every appended record has: its kind and the wall-clock time it was written."""

    KIND: ClassVar[str] = ""
    wall: float | None = None

    def fields(self) -> dict[str, Any]:
        """The record's own keys, as written after ``type`` and ``wall``."""
        out: dict[str, Any] = {}
        for f in dataclasses.fields(self)[1:]:  # after wall
            value, partner = getattr(self, f.name), f.metadata.get("with")
            if partner in out if partner else (_required(f) or f.metadata.get("always")
                                                or value != f.default):
                out[f.name] = _json(value)
        return out

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {"type": self.KIND}
        if self.wall is not None:
            out["wall"] = self.wall
        return {**out, **self.fields()}

    @classmethod
    def refused(cls, key: str, problem: str) -> ValueError:
        return ValueError(f"{cls.KIND or 'record'} without a valid {key}: {problem}")

    @classmethod
    def from_json(cls: type[R], d: Mapping[str, Any]) -> R:
        refused, nested = cls.refused, cls._nested
        named: dict[str, Any] = {}
        for name, read, required, test, words in _plan(cls):
            if name not in d:
                if required:
                    raise refused(name, "it is missing")
                continue
            value = read(d[name], name, refused, nested)
            if test is not None and value is not None and not test(value):
                raise refused(name, f"must be {words}")
            named[name] = value
        return cls(**named)

    @classmethod
    def _wall(cls, d: Mapping[str, Any]) -> float | None:
        """The time of a record whose other keys are read by hand."""
        return checked(float | None, d.get("wall"), "wall", cls.refused)

    @classmethod
    def _nested(cls, hint: Any, value: Any, key: str) -> Any:
        """A field of a class other than JSON's: a gauge, by its key."""
        assert hint is Gauge, f"{key}: {hint} has no reader"
        if isinstance(value, str):
            with contextlib.suppress(ValueError):
                return Gauge.parse(value)
        raise cls.refused(key, f"{value!r} is not a gauge")


def _json(value: Any) -> Any:
    return [_json(v) for v in value] if isinstance(value, tuple) else value


def _rest(d: Mapping[str, Any], *named: str) -> dict[str, Any]:
    """A record's keys other than its kind, its time and those ``named``."""
    return {k: v for k, v in d.items() if k not in ("type", "wall", *named)}


@dataclass(frozen=True, kw_only=True)
class ReadingRecord(Record):
    """One stable gauge value, taken at a step of the plan; its gauge's ``leg`` and
    ``gauge_axis`` are written after it."""

    KIND: ClassVar[str] = "reading"
    step: str  # the plan's id of the step, "x/c1/p2"
    gauge: Gauge
    cycle: int
    posture: str | None = None  # the plan's label ("zero", "max", "+12mm"); None imported
    t_s: Finite  # station clock since the campaign started
    q_mm: Triple  # joint coordinates as commanded
    tcp_mm: Triple
    # side each joint came from: +1 below, -1 above
    approach: tuple[int, int, int] = field(metadata=must(
        lambda a: set(a) <= {-1, 0, 1}, "-1, 0 or +1 for each joint"))
    reading_mm: Finite
    raw: str | None = None  # the frame as received
    source: str | None = None  # port/channel the value came from
    # how many gauge values reading_mm is the mean of, and their sample standard
    # deviation (mm); None in sessions before they were recorded, for a value typed by
    # eye, and for one value's spread
    averaged: int | None = field(default=None, metadata=must(
        lambda n: n >= 1, "a count of values, 1 or more"))
    averaged_sd_mm: Finite | None = field(default=None, metadata=must(
        lambda sd: sd >= 0, "0 or more"))

    @property
    def leg(self) -> str:
        return self.gauge.leg

    @property
    def gauge_axis(self) -> str:
        return self.gauge.axis

    def fields(self) -> dict[str, Any]:
        out = super().fields()
        return {"step": out.pop("step"), "gauge": out.pop("gauge").key, "leg": self.leg,
                "gauge_axis": self.gauge_axis, **out}

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> ReadingRecord:
        reading = super().from_json(d)
        if (d.get("leg"), d.get("gauge_axis")) != (reading.leg, reading.gauge_axis):
            raise cls.refused("gauge", "its leg and gauge_axis disagree with it")
        return reading


@dataclass(frozen=True, kw_only=True)
class MoveRecord(Record):
    KIND: ClassVar[str] = "move"
    q_mm: Triple  # as commanded (rounded to the controller's resolution)
    purpose: str  # "posture" or "approach"
    # with maps applied (ogacq.compensation.applied): the target really sent, q_mm
    # being where the joints were meant to land
    commanded_mm: Triple | None = None


@dataclass(frozen=True, kw_only=True)
class GaugesSetRecord(Record):
    KIND: ClassVar[str] = "gauges_set"
    leg: str
    gauges: tuple[str, ...]


@dataclass(frozen=True, kw_only=True)
class FaultRecord(Record):
    """A device fault during a move or a read, retried or not."""

    KIND: ClassVar[str] = "fault"
    during: str  # "move" or "read"
    step: str | None = None  # a read's
    gauge: str | None = field(default=None, metadata=with_("step"))  # a read's
    attempt: int | None
    error: str  # the exception's class name
    message: str
    q_mm: Triple | None = None  # a move's target

    def describe(self) -> str:
        where = " ".join(str(v) for v in (self.during, self.step, self.gauge) if v)
        attempt = f" (attempt {self.attempt})" if self.attempt else ""
        return f"{where}{attempt}: {self.message}"


@dataclass(frozen=True, kw_only=True)
class EndRecord(Record):
    """The campaign ended: ``complete``, or ``stopped``/``interrupted`` with a reason."""

    KIND: ClassVar[str] = "end"
    status: str
    reason: str | None = None
    axes_stopped: bool | None = field(default=None, metadata=with_("reason"))
    readings: int | None = None


@dataclass(frozen=True, kw_only=True)
class ResultRecord(Record):
    """The identification a finished campaign made: the ``ogacq refit --json`` object."""

    KIND: ClassVar[str] = "result"
    params: str
    refit: dict[str, Any] = field(metadata=must(
        lambda r: isinstance(r.get("parameters"), dict), "an object with its parameters"))
    noise_mm: float
    noise_source: str

    def values(self, names: tuple[str, ...]) -> list[float]:
        """The recorded values of parameters ``names`` ("joint_offset.x", ...);
        KeyError when one was not identified."""
        out = []
        for name in names:
            effect, where = name.split(".")
            out.append(float(self.refit["parameters"][effect][where]))
        return out


@dataclass(frozen=True, kw_only=True)
class ResumeRecord(Record):
    KIND: ClassVar[str] = "resume"
    software: str
    after_records: int


@dataclass(frozen=True, kw_only=True)
class StationRecord(Record):
    """The station a resumed campaign continued on (the header holds the first)."""

    KIND: ClassVar[str] = "station"
    description: dict[str, Any]

    def fields(self) -> dict[str, Any]:
        return dict(self.description)

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> StationRecord:
        return cls(wall=cls._wall(d), description=_rest(d))


@dataclass(frozen=True, kw_only=True)
class _HeadedRecord(Record):
    """A record named by one key (``HEAD``, text) and holding whatever else its writer
    notes."""

    HEAD: ClassVar[str] = ""
    details: dict[str, Any] = field(default_factory=dict)

    def fields(self) -> dict[str, Any]:
        return {self.HEAD: getattr(self, self.HEAD), **self.details}

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> Any:
        head = checked(str, d.get(cls.HEAD), cls.HEAD, cls.refused)
        return cls(wall=cls._wall(d), details=_rest(d, cls.HEAD), **{cls.HEAD: head})


@dataclass(frozen=True, kw_only=True)
class OperatorRecord(_HeadedRecord):
    """What the operator did in the wizard: ``action`` and what it concerns."""

    KIND: ClassVar[str] = "operator"
    HEAD: ClassVar[str] = "action"
    action: str


@dataclass(frozen=True, kw_only=True)
class OffsetsRecord(_HeadedRecord):
    """One stage of a write-back's audit trail (``ogacq.writeback.audit``): refused,
    declined, intent, done or failed, with what that stage records."""

    KIND: ClassVar[str] = "offsets"
    HEAD: ClassVar[str] = "stage"
    stage: str


@dataclass(frozen=True, kw_only=True)
class MapsRecord(_HeadedRecord):
    """One stage of a maps write's audit trail (``ogacq.writeback.maps``): refused,
    declined, intent, done or failed, as ``OffsetsRecord`` for the offsets."""

    KIND: ClassVar[str] = "maps"
    HEAD: ClassVar[str] = "stage"
    stage: str


@dataclass(frozen=True, kw_only=True)
class CalibrateRecord(_HeadedRecord):
    """One step of an ``ogacq calibrate`` procedure, in its own log
    (``ogacq.calibration.log``): what was done, and what it found."""

    KIND: ClassVar[str] = "calibrate"
    HEAD: ClassVar[str] = "step"
    step: str


@dataclass(frozen=True, kw_only=True)
class ReconnectRecord(Record):
    """The controller's connection dropped during a move: reconnected (the axes then
    stopped and their state re-read) or given up after every attempt."""

    KIND: ClassVar[str] = "reconnect"
    connected: bool
    attempts: int
    message: str | None = None  # why it was given up
    axes_stopped: bool | None = None
    positions_mm: dict[str, float] | None = None
    alarms: dict[str, int] | None = None


ENVIRONMENT_STAGES = ("start", "end")


@dataclass(frozen=True, kw_only=True)
class EnvironmentRecord(Record):
    """The temperatures at the start or the end of a campaign, degC, and where they
    came from: typed by the operator, read from a sensor, or the simulator's."""

    KIND: ClassVar[str] = "environment"
    stage: str = field(metadata=must(lambda s: s in ENVIRONMENT_STAGES,
                                     " or ".join(ENVIRONMENT_STAGES)))
    ambient_c: Finite | None
    machine_c: Finite | None = field(default=None, metadata=ALWAYS)
    source: str = field(default="typed", metadata=ALWAYS)


@dataclass(frozen=True, kw_only=True)
class OverrideRecord(Record):
    """A refusal overridden, with its reason: ``what`` ("expired-gauge") and its
    ``subject`` ("y_x 12345678"); ``due`` the date it was past."""

    KIND: ClassVar[str] = "override"
    what: str
    subject: str
    due: str | None = field(default=None, metadata=ALWAYS)  # YYYY-MM-DD
    reason: str
    operator: str | None = field(default=None, metadata=ALWAYS)


@dataclass(frozen=True, kw_only=True)
class SettleRecord(Record):
    """How a reading step waited for the machine to come to rest: ``rule`` "stable"
    (ended "stable"; "not moved" when nothing moved since the last reading, its two
    windows read all the same; or "bound" when a gauge waited the plan's settle_s,
    then was read on for at most as long, judged against its rest: one in
    ``unsettled`` was not at rest by then either, one in ``reference`` measured its
    rest scatter over the first bound), "fixed" (ended "time") or "none"
    (ended "not moved", a fixed rule's step that nothing moved before). ``waited_s``:
    machine seconds it took; ``values``: gauge values read meanwhile, per gauge;
    ``u_mm``: per gauge, the standard uncertainty from noise and display step its
    values were judged against (since the rest rule; a session of the earlier rule has
    none). The plan in the header states the rule."""

    KIND: ClassVar[str] = "settle"
    step: str
    rule: str
    ended: str
    waited_s: Finite
    values: dict[str, int] | None = None
    unsettled: tuple[str, ...] = ()
    reference: tuple[str, ...] = ()
    u_mm: dict[str, Finite] | None = None


@dataclass(frozen=True, kw_only=True)
class ReferenceRecord(Record):
    """After a drive was lost (a reconnect, an alarm, a resume): whether its axes kept
    their position reference, as the drives themselves tell it; the homing that
    restored it; the check posture that says whether the readings taken before still
    hold. ``event``: "kept", "lost", "rehomed", "checked" (the check posture read the
    same within ``tolerance_mm``), "check_failed", or "not_checked" (why in
    ``message``)."""

    KIND: ClassVar[str] = "reference"
    event: str
    cause: str | None = None  # what lost the drive: "reconnect", "alarm", "resume"
    axes: dict[str, Any] | None = None  # per axis: position_mm, homed, reasons
    step: str | None = None  # the check posture: the plan's step read again
    differences_mm: dict[str, Finite] | None = None  # per gauge: now minus as recorded
    tolerance_mm: Finite | None = None
    message: str | None = None


@dataclass(frozen=True, kw_only=True)
class PositionRecord(Record):
    """One reading of an ISO 230-2 positioning test (``ogacq.campaign.positioning``):
    the scale along ``axis`` at ``target_mm`` (where the joint is meant to be),
    approached in ``direction`` (+1 upward, -1 downward) in run ``run``;
    ``commanded_mm`` the target the drive took (the maps' correction, rounded to its
    step), ``meant_mm`` where that meant the joint to land (``TargetCorrection.nominal``:
    the target and the drive's rounding)."""

    KIND: ClassVar[str] = "position"
    axis: str = field(metadata=must(lambda a: a in ("x", "y", "z"), "x, y or z"))
    run: int = field(metadata=must(lambda n: n >= 1, "1 or more"))
    direction: int = field(metadata=must(lambda d: d in (-1, 1), "-1 or +1"))
    target_mm: Finite
    commanded_mm: Finite | None = None
    meant_mm: Finite | None = None
    scale_mm: Finite
    t_s: Finite  # station clock since the test started
    raw: str | None = None  # the frame as received
    averaged: int | None = field(default=None, metadata=must(
        lambda n: n >= 1, "a count of values, 1 or more"))
    averaged_sd_mm: Finite | None = field(default=None, metadata=must(
        lambda sd: sd >= 0, "0 or more"))


@dataclass(frozen=True, kw_only=True)
class SalvageRecord(Record):
    """The last record of a session ``ogacq session salvage`` wrote: the damaged file
    it came from, and the lines of it left out with why."""

    KIND: ClassVar[str] = "salvage"
    source: str
    left_out: tuple[tuple[int, str], ...] = ()

    def fields(self) -> dict[str, Any]:
        return {"source": self.source,
                "left_out": [{"line": line, "problem": why} for line, why in self.left_out]}

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> SalvageRecord:
        entries = checked(tuple[dict[str, Any], ...], d.get("left_out", []), "left_out",
                          cls.refused)
        return cls(wall=cls._wall(d),
                   source=checked(str, d.get("source"), "source", cls.refused),
                   left_out=tuple(
                       (checked(int, e.get("line"), f"left_out[{i}].line", cls.refused),
                        checked(str, e.get("problem"), f"left_out[{i}].problem", cls.refused))
                       for i, e in enumerate(entries)))


@dataclass(frozen=True, kw_only=True)
class OtherRecord(Record):
    """A record of a kind this version does not write, kept as it was."""

    kind: str
    content: dict[str, Any]

    def fields(self) -> dict[str, Any]:
        return dict(self.content)

    def to_json(self) -> dict[str, Any]:
        return {"type": self.kind, **({} if self.wall is None else {"wall": self.wall}),
                **self.content}


KINDS: dict[str, Any] = {cls.KIND: cls for cls in (
    ReadingRecord, MoveRecord, GaugesSetRecord, FaultRecord, EndRecord, ResultRecord,
    ResumeRecord, StationRecord, OperatorRecord, OffsetsRecord, ReconnectRecord,
    EnvironmentRecord, OverrideRecord, SettleRecord, ReferenceRecord, SalvageRecord,
    MapsRecord, CalibrateRecord, PositionRecord)}


def record_from_json(d: Mapping[str, Any]) -> Record:
    """The typed record of a decoded line (``seq``, ``prev`` and ``crc`` taken off);
    ``ValueError`` says what a known kind is missing."""
    kind = d.get("type")
    if not isinstance(kind, str):
        raise ValueError("not a session record")
    known = KINDS.get(kind)
    if known is None:
        return OtherRecord(wall=d.get("wall"), kind=kind, content=_rest(d))
    return known.from_json(d)
