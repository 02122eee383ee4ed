"""A session's tail against the history's own count: the seals prove every record of a
file up to its last, and a ``closed`` record each writer's last turn, but a file cut
exactly after an earlier writer's ``closed`` record passes both. The history recorded
the session's record count with every event of it (a campaign, a write-back), so a
file holding fewer records than the history saw lost its tail."""

from __future__ import annotations

from typing import TYPE_CHECKING

from ogacq.record.identity import session_record_id
from ogacq.session.store import LoadedSession

if TYPE_CHECKING:  # the store (its driver) is imported when a history is opened
    from ogacq.history.store import History


def cut_tail(history: History, session: LoadedSession) -> tuple[int, str] | None:
    """(line, why) when ``history`` saw more records of ``session`` than its file holds
    now; None otherwise (or when the history holds nothing of it)."""
    seen = history.records_seen(session_record_id(session))
    held = len(session.records)
    if seen is None or seen <= held:
        return None
    last = session.closure.last_line
    return last, (f"the history recorded {seen} records of this session and the file holds "
                  f"{held}: the records after line {last} were removed")
