"""The records of a session, typed: every writer builds one of these and every reader
gets one back, so a record's keys are spelled in this module only.

On disk each record is one JSON object whose ``type`` names its class here; the
store adds ``seq``, ``prev`` and ``crc`` (``ogacq.session.seal``). ``from_json``
checks what later stages rely on (a reading's step, gauge, posture and numbers)
and raises ``ValueError`` naming what is wrong, which the store reports with the
line. Records of a kind this
version does not know load as :class:`OtherRecord`, untouched.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar, TypeGuard

from ogacq.model.gauges import AXES, Gauge

FORMAT = "ogacq-session/1"

Triple = tuple[float, float, float]


@dataclass(frozen=True, kw_only=True)
class Record:
    """What every appended record has: its kind and the wall-clock time it was written."""

    KIND: ClassVar[str] = ""
    wall: float | None = None

    def fields(self) -> dict[str, Any]:
        """The record's own keys, as written after ``type`` and ``wall``."""
        raise NotImplementedError

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {"type": self.KIND}
        if self.wall is not None:
            out["wall"] = self.wall
        return {**out, **self.fields()}


def _finite(value: Any) -> TypeGuard[float]:
    """A JSON number that is one: finite, and an integer of 64 bits at most (a 400-digit
    one would overflow every float it meets)."""
    if isinstance(value, bool):
        return False
    if isinstance(value, int):
        return -(2**63) <= value < 2**63
    return isinstance(value, float) and math.isfinite(value)


def _integer(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and -(2**63) <= value < 2**63


def _triple(value: Any, check: Callable[[Any], bool]) -> bool:
    return isinstance(value, list) and len(value) == 3 and all(check(v) for v in value)


def _rest(d: Mapping[str, Any], *named: str) -> dict[str, Any]:
    """A record's keys other than its kind, its time and those ``named``."""
    return {k: v for k, v in d.items() if k not in ("type", "wall", *named)}


@dataclass(frozen=True, kw_only=True)
class ReadingRecord(Record):
    """One stable gauge value, taken at a step of the plan."""

    KIND: ClassVar[str] = "reading"
    step: str  # the plan's id of the step, "x/c1/p2"
    gauge: Gauge
    cycle: int
    posture: str | None  # the plan's label ("zero", "max", "+12mm"); None when imported
    t_s: float  # station clock since the campaign started
    q_mm: Triple  # joint coordinates as commanded
    tcp_mm: Triple
    approach: tuple[int, int, int]  # side each joint came from: +1 below, -1 above
    reading_mm: float
    raw: str | None = None  # the frame as received
    source: str | None = None  # port/channel the value came from
    # how many gauge values reading_mm is the mean of, and their sample standard
    # deviation (mm); None in sessions before they were recorded, for a value typed by
    # eye, and for one value's spread
    averaged: int | None = None
    averaged_sd_mm: float | None = None

    # What each key must hold for the code that reads it.
    _CHECKS: ClassVar[dict[str, Any]] = {
        "step": lambda v: isinstance(v, str), "gauge": lambda v: isinstance(v, str),
        "leg": lambda v: v in AXES, "gauge_axis": lambda v: v in AXES, "cycle": _integer,
        "t_s": _finite, "q_mm": lambda v: _triple(v, _finite),
        "tcp_mm": lambda v: _triple(v, _finite),
        "approach": lambda v: _triple(v, lambda a: a in (-1, 0, 1)), "reading_mm": _finite,
    }

    @property
    def leg(self) -> str:
        return self.gauge.leg

    @property
    def gauge_axis(self) -> str:
        return self.gauge.axis

    def fields(self) -> dict[str, Any]:
        out: dict[str, Any] = {"step": self.step, "gauge": self.gauge.key, "leg": self.leg,
                               "gauge_axis": self.gauge_axis, "cycle": self.cycle}
        if self.posture is not None:
            out["posture"] = self.posture
        out.update(t_s=self.t_s, q_mm=list(self.q_mm), tcp_mm=list(self.tcp_mm),
                   approach=list(self.approach), reading_mm=self.reading_mm)
        if self.raw is not None:
            out["raw"] = self.raw
        if self.source is not None:
            out["source"] = self.source
        if self.averaged is not None:
            out["averaged"] = self.averaged
        if self.averaged_sd_mm is not None:
            out["averaged_sd_mm"] = self.averaged_sd_mm
        return out

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> ReadingRecord:
        bad = [k for k, ok in cls._CHECKS.items() if k not in d or not ok(d[k])]
        if not bad:
            try:
                gauge = Gauge.parse(d["gauge"])
            except ValueError:
                bad = ["gauge"]
            else:
                if (gauge.axis, gauge.leg) != (d["gauge_axis"], d["leg"]):
                    bad = ["gauge (its leg and gauge_axis disagree)"]
        if "posture" in d and not isinstance(d["posture"], str):
            bad.append("posture")
        if "averaged" in d and not (_integer(d["averaged"]) and d["averaged"] >= 1):
            bad.append("averaged (a count of values, 1 or more)")
        if "averaged_sd_mm" in d and not (_finite(d["averaged_sd_mm"])
                                          and d["averaged_sd_mm"] >= 0):
            bad.append("averaged_sd_mm")
        if bad:
            raise ValueError(f"reading without a valid {', '.join(bad)}")
        return cls(wall=d.get("wall"), step=d["step"], gauge=gauge, cycle=d["cycle"],
                   posture=d.get("posture"), t_s=d["t_s"], q_mm=tuple(d["q_mm"]),
                   tcp_mm=tuple(d["tcp_mm"]), approach=tuple(d["approach"]),
                   reading_mm=d["reading_mm"], raw=d.get("raw"), source=d.get("source"),
                   averaged=d.get("averaged"), averaged_sd_mm=d.get("averaged_sd_mm"))


@dataclass(frozen=True, kw_only=True)
class MoveRecord(Record):
    KIND: ClassVar[str] = "move"
    q_mm: Triple  # as commanded (rounded to the controller's resolution)
    purpose: str  # "posture" or "approach"
    # with maps applied (ogacq.compensation.applied): the target really sent, q_mm
    # being where the joints were meant to land
    commanded_mm: Triple | None = None

    def fields(self) -> dict[str, Any]:
        out: dict[str, Any] = {"q_mm": list(self.q_mm), "purpose": self.purpose}
        if self.commanded_mm is not None:
            out["commanded_mm"] = list(self.commanded_mm)
        return out

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> MoveRecord:
        commanded = d.get("commanded_mm")
        return cls(wall=d.get("wall"), q_mm=tuple(d.get("q_mm") or ()),
                   purpose=str(d.get("purpose", "")),
                   commanded_mm=tuple(commanded) if commanded else None)


@dataclass(frozen=True, kw_only=True)
class GaugesSetRecord(Record):
    KIND: ClassVar[str] = "gauges_set"
    leg: str
    gauges: tuple[str, ...]

    def fields(self) -> dict[str, Any]:
        return {"leg": self.leg, "gauges": list(self.gauges)}

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> GaugesSetRecord:
        return cls(wall=d.get("wall"), leg=str(d.get("leg", "")),
                   gauges=tuple(d.get("gauges") or ()))


@dataclass(frozen=True, kw_only=True)
class FaultRecord(Record):
    """A device fault during a move or a read, retried or not."""

    KIND: ClassVar[str] = "fault"
    during: str  # "move" or "read"
    attempt: int | None
    error: str  # the exception's class name
    message: str
    step: str | None = None  # a read's
    gauge: str | None = None  # a read's
    q_mm: Triple | None = None  # a move's target

    def fields(self) -> dict[str, Any]:
        out: dict[str, Any] = {"during": self.during}
        if self.step is not None:
            out.update(step=self.step, gauge=self.gauge)
        out.update(attempt=self.attempt, error=self.error, message=self.message)
        if self.q_mm is not None:
            out["q_mm"] = list(self.q_mm)
        return out

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> FaultRecord:
        q = d.get("q_mm")
        return cls(wall=d.get("wall"), during=str(d.get("during", "")),
                   attempt=d.get("attempt"), error=str(d.get("error", "")),
                   message=str(d.get("message", "fault")), step=d.get("step"),
                   gauge=d.get("gauge"), q_mm=tuple(q) if q else None)

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
    axes_stopped: bool | None = None
    readings: int | None = None

    def fields(self) -> dict[str, Any]:
        out: dict[str, Any] = {"status": self.status}
        if self.reason is not None:
            out.update(reason=self.reason, axes_stopped=self.axes_stopped)
        if self.readings is not None:
            out["readings"] = self.readings
        return out

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> EndRecord:
        return cls(wall=d.get("wall"), status=str(d.get("status", "incomplete")),
                   reason=d.get("reason"), axes_stopped=d.get("axes_stopped"),
                   readings=d.get("readings"))


@dataclass(frozen=True, kw_only=True)
class ResultRecord(Record):
    """The identification a finished campaign made: the ``ogacq refit --json`` object."""

    KIND: ClassVar[str] = "result"
    params: str
    refit: dict[str, Any]
    noise_mm: float
    noise_source: str

    def fields(self) -> dict[str, Any]:
        return {"params": self.params, "refit": self.refit, "noise_mm": self.noise_mm,
                "noise_source": self.noise_source}

    def values(self, names: tuple[str, ...]) -> list[float]:
        """The recorded values of parameters ``names`` ("joint_offset.x", ...);
        KeyError when one was not identified."""
        out = []
        for name in names:
            effect, where = name.split(".")
            out.append(float(self.refit["parameters"][effect][where]))
        return out

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> ResultRecord:
        refit = d.get("refit")
        if not isinstance(refit, dict) or not isinstance(refit.get("parameters"), dict):
            raise ValueError("result without a valid refit")
        return cls(wall=d.get("wall"), params=str(d.get("params", "offsets")), refit=refit,
                   noise_mm=d.get("noise_mm", math.nan),
                   noise_source=str(d.get("noise_source", "")))


@dataclass(frozen=True, kw_only=True)
class ResumeRecord(Record):
    KIND: ClassVar[str] = "resume"
    software: str
    after_records: int

    def fields(self) -> dict[str, Any]:
        return {"software": self.software, "after_records": self.after_records}

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> ResumeRecord:
        return cls(wall=d.get("wall"), software=str(d.get("software", "?")),
                   after_records=int(d.get("after_records", 0)))


@dataclass(frozen=True, kw_only=True)
class StationRecord(Record):
    """The station a resumed campaign continued on (the header holds the first)."""

    KIND: ClassVar[str] = "station"
    description: dict[str, Any]

    def fields(self) -> dict[str, Any]:
        return dict(self.description)

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> StationRecord:
        return cls(wall=d.get("wall"), description=_rest(d))


@dataclass(frozen=True, kw_only=True)
class _HeadedRecord(Record):
    """A record named by one key (``HEAD``) and holding whatever else its writer notes."""

    HEAD: ClassVar[str] = ""
    details: dict[str, Any] = field(default_factory=dict)

    def fields(self) -> dict[str, Any]:
        return {self.HEAD: getattr(self, self.HEAD), **self.details}

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> Any:
        return cls(wall=d.get("wall"), details=_rest(d, cls.HEAD),
                   **{cls.HEAD: str(d.get(cls.HEAD, ""))})


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

    def fields(self) -> dict[str, Any]:
        out: dict[str, Any] = {"connected": self.connected, "attempts": self.attempts}
        extra = {"message": self.message, "axes_stopped": self.axes_stopped,
                 "positions_mm": self.positions_mm, "alarms": self.alarms}
        return {**out, **{k: v for k, v in extra.items() if v is not None}}

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> ReconnectRecord:
        return cls(wall=d.get("wall"), connected=bool(d.get("connected")),
                   attempts=int(d.get("attempts") or 0), message=d.get("message"),
                   axes_stopped=d.get("axes_stopped"), positions_mm=d.get("positions_mm"),
                   alarms=d.get("alarms"))


ENVIRONMENT_STAGES = ("start", "end")
ENVIRONMENT_SOURCES = ("typed", "sensor", "simulator")


def _temperature(value: Any) -> float | None:
    return float(value) if _finite(value) else None


@dataclass(frozen=True, kw_only=True)
class EnvironmentRecord(Record):
    """The temperatures at the start or the end of a campaign, degC, and where they
    came from: typed by the operator, read from a sensor, or the simulator's."""

    KIND: ClassVar[str] = "environment"
    stage: str  # "start" or "end"
    ambient_c: float | None
    machine_c: float | None = None
    source: str = "typed"

    def fields(self) -> dict[str, Any]:
        return {"stage": self.stage, "ambient_c": self.ambient_c,
                "machine_c": self.machine_c, "source": self.source}

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> EnvironmentRecord:
        if d.get("stage") not in ENVIRONMENT_STAGES:
            raise ValueError(f"environment without a valid stage ({', '.join(ENVIRONMENT_STAGES)})")
        for key in ("ambient_c", "machine_c"):
            if d.get(key) is not None and _temperature(d[key]) is None:
                raise ValueError(f"environment with an invalid {key}")
        return cls(wall=d.get("wall"), stage=d["stage"], ambient_c=_temperature(d.get("ambient_c")),
                   machine_c=_temperature(d.get("machine_c")),
                   source=str(d.get("source") or "typed"))


@dataclass(frozen=True, kw_only=True)
class OverrideRecord(Record):
    """A refusal overridden, with its reason: ``what`` ("expired-gauge") and its
    ``subject`` ("y_x 12345678"); ``due`` the date it was past."""

    KIND: ClassVar[str] = "override"
    what: str
    subject: str
    reason: str
    due: str | None = None  # YYYY-MM-DD
    operator: str | None = None

    def fields(self) -> dict[str, Any]:
        return {"what": self.what, "subject": self.subject, "due": self.due,
                "reason": self.reason, "operator": self.operator}

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> OverrideRecord:
        if not isinstance(d.get("what"), str) or not isinstance(d.get("reason"), str):
            raise ValueError("override without its what and reason")
        return cls(wall=d.get("wall"), what=d["what"], subject=str(d.get("subject") or ""),
                   reason=d["reason"], due=d.get("due") if isinstance(d.get("due"), str)
                   else None, operator=d.get("operator") if isinstance(d.get("operator"), str)
                   else None)


@dataclass(frozen=True, kw_only=True)
class SettleRecord(Record):
    """How a reading step waited for the machine to come to rest: ``rule`` "stable"
    (ended "stable", or "bound" when a gauge waited the plan's settle_s: one in
    ``unsettled`` was never at rest, one in ``reference`` measured its rest scatter
    there), "fixed" (ended "time") or "none" (ended "not moved": nothing moved since
    the last reading). ``waited_s``: machine seconds it took; ``values``: gauge
    values read meanwhile, per gauge; ``u_mm``: per gauge, the standard uncertainty
    from noise and display step its values were judged against (since the rest rule;
    a session of the earlier rule has none). The plan in the header states the rule."""

    KIND: ClassVar[str] = "settle"
    step: str
    rule: str
    ended: str
    waited_s: float
    values: dict[str, int] | None = None
    unsettled: tuple[str, ...] = ()
    reference: tuple[str, ...] = ()
    u_mm: dict[str, float] | None = None

    def fields(self) -> dict[str, Any]:
        out: dict[str, Any] = {"step": self.step, "rule": self.rule, "ended": self.ended,
                               "waited_s": self.waited_s}
        if self.values is not None:
            out["values"] = self.values
        if self.unsettled:
            out["unsettled"] = list(self.unsettled)
        if self.reference:
            out["reference"] = list(self.reference)
        if self.u_mm is not None:
            out["u_mm"] = self.u_mm
        return out

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> SettleRecord:
        waited = d.get("waited_s")
        u_mm = d.get("u_mm")
        return cls(wall=d.get("wall"), step=str(d.get("step", "")), rule=str(d.get("rule", "")),
                   ended=str(d.get("ended", "")),
                   waited_s=float(waited) if _finite(waited) else math.nan,
                   values=d.get("values"), unsettled=tuple(d.get("unsettled") or ()),
                   reference=tuple(d.get("reference") or ()),
                   u_mm={str(g): float(u) for g, u in u_mm.items() if _finite(u)}
                   if isinstance(u_mm, dict) else None)


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
    differences_mm: dict[str, float] | None = None  # per gauge: now minus as recorded
    tolerance_mm: float | None = None
    message: str | None = None

    def fields(self) -> dict[str, Any]:
        extra = {"cause": self.cause, "axes": self.axes, "step": self.step,
                 "differences_mm": self.differences_mm, "tolerance_mm": self.tolerance_mm,
                 "message": self.message}
        return {"event": self.event, **{k: v for k, v in extra.items() if v is not None}}

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> ReferenceRecord:
        differences = d.get("differences_mm")
        return cls(wall=d.get("wall"), event=str(d.get("event", "")), cause=d.get("cause"),
                   axes=d.get("axes") if isinstance(d.get("axes"), dict) else None,
                   step=d.get("step"),
                   differences_mm={str(g): float(v) for g, v in differences.items()
                                   if _finite(v)} if isinstance(differences, dict) else None,
                   tolerance_mm=d.get("tolerance_mm") if _finite(d.get("tolerance_mm"))
                   else None, message=d.get("message"))


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
        entries = given if isinstance(given := d.get("left_out"), list) else []
        return cls(wall=d.get("wall"), source=str(d.get("source", "")),
                   left_out=tuple((int(e.get("line", 0)), str(e.get("problem", "")))
                                  for e in entries if isinstance(e, dict)
                                  and _integer(e.get("line", 0))))


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
    MapsRecord, CalibrateRecord)}


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
