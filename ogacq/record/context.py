"""Who, what, with which instruments, when and at what temperature: the context of
a calibration, read from its session (docs/calibration-record.md 2).

``calibration_context(session)`` reads the session header's ``identity``,
``instruments`` and ``date`` and its environment and override records. A session
written before these were recorded reads with what it does not say as None (its
gauges' serials from the station, its date from when the session was created),
never an error.
"""

from __future__ import annotations

import datetime
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from ogacq.io.dates import moment_or_none
from ogacq.model.instrument import Instrument
from ogacq.session.header import SessionHeader
from ogacq.session.records import EnvironmentRecord, OverrideRecord
from ogacq.session.store import LoadedSession

__all__ = ["CalibrationContext", "Environment", "Instrument", "Override", "Temperatures",
           "calibration_context"]


@dataclass(frozen=True)
class Temperatures:
    """The temperatures at one stage of a campaign, degC (None: not measured)."""

    ambient_c: float | None
    machine_c: float | None
    source: str | None  # "typed", "sensor" or "simulator"

    def to_json(self) -> dict[str, Any]:
        return {"ambient_c": self.ambient_c, "machine_c": self.machine_c,
                "source": self.source}


@dataclass(frozen=True)
class Environment:
    start: Temperatures | None = None
    end: Temperatures | None = None

    @property
    def temperature_c(self) -> float | None:
        """The legs' temperature the campaign ran at: the machine's when measured,
        else the ambient (start and end averaged when both are known)."""
        found = [s.machine_c if s.machine_c is not None else s.ambient_c
                 for s in (self.start, self.end) if s is not None]
        values = [v for v in found if v is not None]
        return sum(values) / len(values) if values else None

    def to_json(self) -> dict[str, Any]:
        return {"start": self.start.to_json() if self.start else None,
                "end": self.end.to_json() if self.end else None}


@dataclass(frozen=True)
class Override:
    what: str  # "expired-gauge"
    subject: str  # "y_x 12345678"
    reason: str
    due: datetime.date | None = None
    operator: str | None = None

    def to_json(self) -> dict[str, Any]:
        return {"what": self.what, "subject": self.subject, "reason": self.reason,
                "due": self.due.isoformat() if self.due else None, "operator": self.operator}


@dataclass(frozen=True)
class CalibrationContext:
    machine_name: str | None
    machine_serial: str | None
    operator: str | None
    date: datetime.datetime | None  # the campaign's (a rehearsal's when simulated_date)
    instruments: tuple[Instrument, ...]
    environment: Environment
    overrides: tuple[Override, ...]
    simulated_date: bool = False

    def expired(self, instrument: Instrument) -> bool | None:
        """Was the instrument past its due date on the campaign's date (None: unknown)?"""
        return None if self.date is None else instrument.expired(self.date.date())

    def instrument(self, gauge: str) -> Instrument | None:
        return next((i for i in self.instruments if i.gauge == gauge), None)


def calibration_context(session: LoadedSession) -> CalibrationContext:
    header = session.header
    identity = _mapping(header.identity)
    machine = _mapping(header.machine)
    simulator = _mapping(header.simulator)
    date = moment_or_none(header.date) or moment_or_none(header.created)
    return CalibrationContext(
        machine_name=_text(identity.get("machine")) or _text(machine.get("name")),
        machine_serial=_text(identity.get("serial")) or _text(machine.get("serial")),
        operator=_text(identity.get("operator")),
        date=date,
        instruments=_instruments(header),
        environment=_environment(session),
        overrides=tuple(Override(r.what, r.subject, r.reason, _date(r.due), r.operator)
                        for r in session.of_type(OverrideRecord)),
        simulated_date=bool(simulator.get("simulated_date")))


def _instruments(header: SessionHeader) -> tuple[Instrument, ...]:
    given = header.instruments
    if given is not None:
        return tuple(Instrument.from_json(e) for e in given if isinstance(e, Mapping))
    # written before instruments were recorded: the station's serials, nothing more
    return tuple(Instrument(key, serial=_text(_mapping(g).get("serial")))
                 for key, g in header.gauges.items())


def _environment(session: LoadedSession) -> Environment:
    stages: dict[str, Temperatures] = {}
    for r in session.of_type(EnvironmentRecord):
        # the first start (a resume does not restart the campaign), the last end
        if r.stage == "start" and "start" in stages:
            continue
        stages[r.stage] = Temperatures(r.ambient_c, r.machine_c, r.source)
    return Environment(stages.get("start"), stages.get("end"))


def _date(value: str | None) -> datetime.date | None:
    moment = moment_or_none(value)
    return moment.date() if moment else None


def _mapping(value: Any) -> Mapping[str, Any]:
    return value if isinstance(value, Mapping) else {}


def _text(value: Any) -> str | None:
    return value if isinstance(value, str) and value else None
