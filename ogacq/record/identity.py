"""A record's identity, known without building the record: its id and the session
file's digest. Light on purpose: the history asks whether a session's record is
already there before it pays for building one (the uncertainty evaluation)."""

from __future__ import annotations

import hashlib

from ogacq.io.dates import moment_or_none
from ogacq.io.errors import InputError
from ogacq.record.context import calibration_context
from ogacq.session.store import LoadedSession


def record_id(header_line: bytes, date: str | None) -> str:
    """``OGQ-<date>-<first 8 hex of the SHA-256 of the session's header line>``: the
    header holds the session's creation time, station and plan, so the same session
    always gives the same id and two sessions never share one (no source: the
    project's own rule, docs/calibration-record.md section 5)."""
    digest = hashlib.sha256(header_line.rstrip(b"\r\n")).hexdigest()[:8]
    return f"OGQ-{compact_date(date)}-{digest}"


def compact_date(date: str | None) -> str:
    """``2026-01-10T09:00:00`` -> ``20260110``; ``undated`` when there is no date."""
    day = moment_or_none(date)
    return f"{day.year:04d}{day.month:02d}{day.day:02d}" if day is not None else "undated"


def session_record_id(session: LoadedSession) -> str:
    """The id the record of ``session`` has (without building the record)."""
    header_line, _ = session_digest(session)
    date = calibration_context(session).date
    return record_id(header_line, date.isoformat() if date is not None else None)


def session_digest(session: LoadedSession) -> tuple[bytes, str]:
    """The header line and the SHA-256 of the session file as it was loaded."""
    try:
        with open(session.path, "rb") as f:
            data = f.read(session.size_bytes) if session.size_bytes else f.read()
    except OSError as exc:
        raise InputError(session.path, f"cannot read session: {exc.strerror or exc}") from None
    return data.split(b"\n", 1)[0], hashlib.sha256(data).hexdigest()
