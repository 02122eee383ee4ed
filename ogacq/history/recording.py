"""Recording what a command finished into the machine's history.

Called after the session is closed: the session is the source of truth and is
already safe on disk, so a history that cannot be reached only costs a warning
that says how to add the session later (``ogacq history add``). Nothing here
raises for a history failure.

What is recorded is the ``ogacq-record/1`` document of the session
(``ogacq.record.document.build_record``), with, for a write-back, the operation
its audit records describe. A session whose campaign has not finished gives no
calibration (nor diagnosis): its complete result is recorded when the campaign
completes, whoever analysed it first. A write-back it holds is recorded all the
same: the controller was changed.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ogacq.errors import OgacqError
from ogacq.history.entries import MapsWriteBack, Recorded, WriteBack, event_key
from ogacq.logs import logger
from ogacq.session.state import completeness
from ogacq.session.store import LoadedSession, load_session

if TYPE_CHECKING:  # the store is imported when something is recorded, not at start-up
    from ogacq.history.location import HistoryLocation
    from ogacq.history.store import History

log = logger("ogacq.history")

Say = Callable[[str], None]


def _say(text: str) -> None:
    print(text, file=sys.stderr, flush=True)  # stdout stays the command's own (its --json)


def session_record(session: LoadedSession) -> dict[str, Any]:
    """The session's record, as ``ogacq report`` writes it beside the page."""
    from ogacq.record.document import build_record

    return build_record(session)


def writebacks_of(session: LoadedSession) -> list[WriteBack]:
    """The write-backs and restores the session's audit records describe."""
    # the audit's readers (and the drives' profiles behind them) imported only here: a
    # diagnosis of a finished campaign records none of them
    from ogacq.writeback.audit import operations

    return [WriteBack(op.operation, op.action, op.status, op.old_mm, op.new_mm, op.profile,
                      op.wall, op.restores) for op in operations(session)]


def maps_writebacks_of(session: LoadedSession) -> list[MapsWriteBack]:
    """The maps writes and restores the session's audit records describe."""
    from ogacq.writeback.maps import MapsFile

    return [MapsWriteBack(op.operation, op.action, op.status, str(op.path),
                          tuple(m.to_json() for m in op.old_maps.values()), op.old_checksum,
                          tuple(m.to_json() for m in op.new_maps.values()), op.new_checksum,
                          op.wall, op.restores) for op in MapsFile.operations(session)]


def record_session(history: History, session: LoadedSession,
                   record: Mapping[str, Any] | None = None) -> Recorded:
    """The session's calibration (when its campaign completed) and every write-back of
    its audit, offsets and maps (each once)."""
    record = dict(record) if record is not None else session_record(session)
    where = str(session.path.resolve())
    done = Recorded()
    if completeness(session, probe_lock=False).complete:
        done += history.record_calibration(record, session_path=where)
    for writeback in writebacks_of(session):
        done += history.record_writeback(record, writeback, session_path=where)
    for maps in maps_writebacks_of(session):
        done += history.record_maps_writeback(record, maps, session_path=where)
    return done


def _later(session_path: Path, location: HistoryLocation) -> str:
    named = "" if location.origin == "ogacq's data folder" else \
        f" --history {location.describe()}"
    return f"add it later with `ogacq history add {session_path}{named}`"


def _summary(recorded: Recorded) -> str:
    kinds = [key.split(":")[0] for key in recorded.new]
    counted = ", ".join(f"{kinds.count(k)} {k}{'s' if kinds.count(k) > 1 else ''}"
                        for k in dict.fromkeys(kinds))
    return counted or "nothing new"


def record_after(session_path: Path, option: str | None, action: str, *,
                 record_with: Callable[[History, LoadedSession], Recorded] | None = None,
                 location: HistoryLocation | None = None, say: Say = _say,
                 accept_edited: bool = False,
                 found_with: Callable[[History, LoadedSession], Recorded | None] | None = None,
                 ) -> Recorded | None:
    """Record the finished ``session_path`` (``action``: what finished, for the
    messages) into ``location``, else the history the option, the environment or the
    session names; None when recording is switched off or failed (a warning then
    says how to add it later), or when the session's campaign has not finished and
    holds no write-back (said). ``accept_edited``: the user accepted the session's
    edits (its record says so). ``found_with``: what the history holds already of
    what ``record_with`` records, asked first of the history opened to read (None:
    not all of it), so that nothing to record opens it to write."""
    try:
        if location is None:
            from ogacq.history.location import history_for_session

            try:
                location = history_for_session(option, session_path)
            except OgacqError as exc:
                log.warning("%s not recorded in the history: %s", action, exc)
                return None
            if location is None:  # `none`: nothing of the database is imported
                return None
        from ogacq.history.store import History
    except ImportError as exc:  # an install without its driver: the session is kept all the same
        log.warning("%s not recorded in the history: %s; add it later with `ogacq history add "
                    "%s`", action, exc, session_path)
        return None
    try:
        session = load_session(session_path, accept_edited=accept_edited)
        state = completeness(session)
        if not state.complete and (record_with is not None or not writebacks_of(session)):
            say(f"history: nothing recorded: {state.describe()}; the campaign's result is "
                "recorded when it completes")
            return None
        found = _found(location, session, found_with) if found_with is not None else None
        if found is not None:
            say(f"history: {_summary(found)} recorded in {location.describe()}")
            return found
        with History.open(location) as history:
            first_met = filed_by_name(history, session)
            recorded = (record_with or record_session)(history, session)
    except (OgacqError, ValueError, OSError) as exc:
        log.warning("%s not recorded in the history: %s; %s", action, exc,
                    _later(session_path, location))
        return None
    except Exception as exc:  # the session is safe whatever failed here: say it, go on
        log.warning("%s not recorded in the history (%s: %s); %s", action,
                    type(exc).__name__, exc, _later(session_path, location))
        return None
    say(f"history: {_summary(recorded)} recorded in {location.describe()}")
    if first_met is not None and recorded.new:
        say(first_met)
    return recorded


def _found(location: HistoryLocation, session: LoadedSession,
           found_with: Callable[[History, LoadedSession], Recorded | None]) -> Recorded | None:
    """``found_with`` asked of the history opened to read: not checked as one opened to
    write is (its every stored record read: ~0.1 s in a history of 600 events), nor its
    schema made, since nothing is written. None when it cannot say (no history yet, one
    it cannot read): the history opened to write says why, where it matters."""
    from ogacq.history.store import History

    try:
        with History.open(location, create=False) as history:
            return found_with(history, session)
    except (OgacqError, ValueError, OSError):
        return None


def filed_by_name(history: History, session: LoadedSession) -> str | None:
    """What a machine without a serial is filed as, said the first time this history
    meets it: its name is then its identity ("NAME (no serial)"), the same at every later
    campaign; a serial given later makes it a new machine here. A user's machine file
    is never rewritten to add one. None for a machine with a serial, or one met before."""
    machine = session.header.machine or {}
    name, serial = str(machine.get("name") or "").strip(), machine.get("serial")
    if not name or serial or history.machine(name, "") is not None:
        return None
    where = session.header.machine_file or "its machine file"
    return (f"history: {name!r} has no serial: filed as '{name} (no serial)', its identity "
            f"in this history from now on; `serial = \"...\"` in {where} tells it from "
            "another machine of that name (filed then as a new machine)")


def recorded_unchanged(history: History, session: LoadedSession,
                       record_id: str) -> dict[str, Any] | None:
    """The record the history stored with the session's calibration (``ogacq run`` and
    ``history add`` record it), when the session is byte for byte the file it was built
    from: that record, not built again (its uncertainty's Monte-Carlo check is most of a
    first diagnosis's CPU). None when the history has none, or the session changed since
    (a write-back appended: its record says more)."""
    from ogacq.history.entries import typed_record
    from ogacq.record.identity import session_digest

    stored = history.calibration_record(record_id)
    if stored is None:
        return None
    _, sha256 = session_digest(session)
    return stored if typed_record(stored).session_file.sha256 == sha256 else None


def record_campaign(session_path: Path, option: str | None, *, say: Say = _say,
                    record: Mapping[str, Any] | None = None) -> None:
    """A finished campaign (run, resume, demo, the wizard); ``record``: its record,
    when the command built it already."""
    with_record = None if record is None else \
        (lambda history, session: record_session(history, session, record))
    record_after(session_path, option, "the campaign", say=say, record_with=with_record)


def record_diagnosis(session_path: Path, diagnosis: Mapping[str, Any],
                     option: str | None, *, accept_edited: bool = False) -> None:
    """``ogacq diagnose`` of a session: its findings beside the session's record (a
    session not finished gives nothing: its campaign's result comes when it does)."""

    def diagnosed(history: History, session: LoadedSession) -> Recorded | None:
        """The session's calibration and diagnosis, when the history holds both (a
        diagnosis is kept once per record: nothing to build)."""
        from ogacq.record.identity import session_record_id

        record_id = session_record_id(session)
        keys = [event_key("calibration", record_id), event_key("diagnosis", record_id)]
        present = history.present(keys)
        return Recorded(present=present) if present == keys else None

    def with_diagnosis(history: History, session: LoadedSession) -> Recorded:
        from ogacq.record.identity import session_record_id

        found = diagnosed(history, session)
        if found is not None:
            return found
        record_id = session_record_id(session)
        record = recorded_unchanged(history, session, record_id) or session_record(session)
        where = str(session.path.resolve())
        done = history.record_calibration(record, session_path=where)
        done += history.record_diagnosis(record, diagnosis, session_path=where)
        return done

    record_after(session_path, option, "the diagnosis", record_with=with_diagnosis,
                 accept_edited=accept_edited, found_with=diagnosed)


def record_calibrate(session_path: Path, option: str | None, record: Mapping[str, Any],
                     procedure: str, details: Mapping[str, Any], *, say: Say = _say,
                     validation: Path | None = None,
                     location: HistoryLocation | None = None) -> None:
    """After ``ogacq calibrate``: the calibration session (its record as found and as
    left, its write-backs and restores), the validation campaign, and the procedure's
    outcome."""

    def with_outcome(history: History, session: LoadedSession) -> Recorded:
        done = record_session(history, session, record)
        if validation is not None:
            done += record_session(history, load_session(validation))
        done += history.record_calibrate(record, procedure, details,
                                         session_path=str(session.path.resolve()))
        return done

    record_after(session_path, option, "the calibration", record_with=with_outcome, say=say,
                 location=location)


def procedure_history(option: str | None, anchor: Path) -> HistoryLocation | None:
    """The one history a calibrate procedure records into: the option's, or the one
    beside its calibration campaign (``anchor``), wherever its other sessions are."""
    from ogacq.history.location import history_for_session

    try:
        return history_for_session(option, anchor)
    except OgacqError as exc:
        log.warning("the calibration will not be recorded in the history: %s", exc)
        return None


def record_writebacks(session_path: Path, option: str | None,
                      location: HistoryLocation | None = None, *,
                      accept_edited: bool = False) -> None:
    """After ``offsets write`` or ``restore``: every operation of the session's audit
    (the one just made among them), into ``location`` when the states came from one."""
    record_after(session_path, option, "the write-back", location=location,
                 accept_edited=accept_edited)
