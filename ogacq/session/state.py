"""Whether a session's campaign finished, and what an analysis of it must say.

A campaign is complete when its session holds the end record ``complete``. Until
then it is *partial*: running (a writer holds the session's lock), stopped or
interrupted (its end record says why), or without an end record at all (killed,
or the disk cut it). A partial session is analysed only when the user asks for it
(``--partial``), every output then says ``partial: N of M planned readings``, and
nothing of it enters the machine's history as a calibration: the campaign's
complete result does, when it completes.

:func:`session_notes` gathers what every analysis prints about the session it
read (partial, edited, an older format); :func:`state_json` the same for JSON.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

from ogacq.errors import OgacqError, Refused
from ogacq.protocol.plan import ProtocolConfig, reading_steps
from ogacq.session.convert import session_machine
from ogacq.session.records import EndRecord, FaultRecord, ResumeRecord
from ogacq.session.seal import SEALED
from ogacq.session.store import LoadedSession, lock_holder

COMPLETE = "complete"
RUNNING = "running"
NO_END = "no end record"


@dataclass(frozen=True)
class Completeness:
    """How far a session's campaign went: ``readings`` of ``planned`` (None when the
    session states no plan), its ``status`` and, when running, who writes it."""

    readings: int
    planned: int | None
    status: str  # complete, running, stopped, interrupted, no end record
    reason: str | None = None  # a stop's
    holder: str | None = None  # the writer holding the session now

    @property
    def complete(self) -> bool:
        return self.status == COMPLETE

    def describe(self) -> str:
        """``partial: 36 of 72 planned readings (...)``, or ``complete: 72 readings``."""
        if self.complete:
            return f"complete: {self.readings} readings"
        of = (f"{self.readings} of {self.planned} planned readings" if self.planned is not None
              else f"{self.readings} readings, the plan not recorded")
        return f"partial: {of} ({self._why()})"

    def _why(self) -> str:
        if self.status == RUNNING:
            return f"the campaign is running: {self.holder}"
        if self.status == NO_END:
            return "no end record: the campaign was killed, or its disk cut it"
        return f"{self.status}: {self.reason}" if self.reason else self.status

    def to_json(self) -> dict[str, Any]:
        return {"readings": self.readings, "planned": self.planned, "status": self.status,
                "reason": self.reason, "running": self.holder, "says": self.describe()}


def planned_readings(session: LoadedSession) -> int | None:
    """The readings the session's plan takes on its machine; None when it states none."""
    plan = session.header.plan
    if plan is None:
        return None
    try:
        config = ProtocolConfig.from_dict(plan)
        return sum(len(step.gauges) for step in reading_steps(config, session_machine(session)))
    except (OgacqError, TypeError, ValueError, KeyError, AttributeError):
        return None


@dataclass(frozen=True)
class CampaignStatus:
    """How the session's campaign ended, as its record states it (``campaign``:
    status, readings, planned, reason), with the faults it met and the records a crash
    cut (load warnings)."""

    status: str  # "complete", "stopped", "interrupted", "incomplete"
    readings: int
    planned: int | None
    reason: str | None
    faults: tuple[str, ...]
    torn: tuple[str, ...]

    @property
    def complete(self) -> bool:
        return self.status == COMPLETE


def campaign_status(session: LoadedSession) -> CampaignStatus:
    """The last end record's status, or ``incomplete`` when there is none, or when the
    campaign was resumed after it and has not ended since."""
    last = _last_end(session)
    status, reason = (last.status, last.reason) if last else ("incomplete", None)
    faults = tuple(f.describe() for f in session.of_type(FaultRecord))
    return CampaignStatus(status, len(session.readings), planned_readings(session), reason,
                          faults, tuple(session.warnings))


def _last_end(session: LoadedSession) -> EndRecord | None:
    """The last end record after the last resume: a resumed campaign's earlier stop is
    history."""
    last: EndRecord | None = None
    for record in session.records:
        if isinstance(record, ResumeRecord):
            last = None
        elif isinstance(record, EndRecord):
            last = record
    return last


def completeness(session: LoadedSession, *, probe_lock: bool = True) -> Completeness:
    """The session's campaign as it stands; ``probe_lock``: ask whether a writer holds it."""
    readings = len(session.recorded())
    planned = planned_readings(session)
    if session.finished:
        return Completeness(readings, planned, COMPLETE)
    holder = lock_holder(session.path) if probe_lock else None
    if holder is not None:
        return Completeness(readings, planned, RUNNING, holder=holder)
    last = _last_end(session)
    if last is None:
        return Completeness(readings, planned, NO_END)
    return Completeness(readings, planned, last.status, last.reason)


def unproven_end(session: LoadedSession) -> str | None:
    """Why the session's file may not end where its last writer ended it (a torn record,
    or no ``closed`` record after the last: killed, or cut), or None: closed, written
    now by the writer holding its lock, or written before the closed records."""
    problem = session.closure.problem()
    if problem is None or session.closure.torn_line is not None:
        return problem
    return None if lock_holder(session.path) is not None else problem


def unsealed(session: LoadedSession) -> tuple[int, str] | None:
    """(line, why) a session cannot vouch for all it held, edits aside (those are the
    integrity's): written without the chained seals, or an end not closed; None when
    it can."""
    if session.integrity.mode != SEALED:
        return 1, f"{session.integrity.mode}: written without the chained seals (a seal " \
                  "stripped, or an older ogacq): an edit or a removed record cannot be found"
    problem = unproven_end(session)
    if problem is None:
        return None
    closure = session.closure
    return (closure.torn_line or closure.last_line), problem


def taken_as_it_stands(session: LoadedSession, line: int, problem: str) -> LoadedSession:
    """``session`` with ``problem`` among the edits the user accepted: every output and
    the record (so the history) then say it."""
    edited = (*session.integrity.edited, (line, problem))
    return replace(session, integrity=replace(session.integrity, edited=edited))


def require_complete(session: LoadedSession, partial: bool) -> Completeness:
    """The session's completeness; Refused (exit 4) when its campaign has not finished
    and the user did not ask for a partial analysis."""
    state = completeness(session)
    if state.complete or partial:
        return state
    if state.status == RUNNING:
        then = "wait until it has finished"
    elif session.header.campaign_file:
        then = f"finish it with `ogacq resume {session.path}`"
    else:
        then = "its campaign cannot be resumed"
    raise Refused(f"{session.path}: {state.describe()}; {then}, or analyse what it holds "
                  "with --partial (every output then says so, and nothing of it enters the "
                  "history)")


def session_notes(session: LoadedSession, state: Completeness | None = None) -> list[str]:
    """What an analysis of ``session`` says before its results: partial, edited, an
    older format (nothing for a complete, sealed, untouched session)."""
    state = state or completeness(session)
    return ([] if state.complete else [state.describe()]) + session.integrity.notes()


def state_json(session: LoadedSession, state: Completeness | None = None) -> dict[str, Any]:
    """The keys an analysis's JSON gains for ``session`` (none when it is complete,
    sealed and untouched): ``partial``, ``edited``, ``integrity``."""
    state = state or completeness(session)
    out: dict[str, Any] = {}
    if not state.complete:
        out["partial"] = state.to_json()
    integrity = session.integrity.to_json()
    if integrity["edited"]:
        out["edited"] = integrity["edited"]
    if integrity["integrity"] != "sealed":
        out["integrity"] = integrity["integrity"]
    return out
