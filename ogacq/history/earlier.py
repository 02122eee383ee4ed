"""The earlier calibrations ``ogacq report`` plots: the machine's entries in its
history database (docs/calibration-record.md section 6), read without writing.

The history is the one the campaign recorded into: ``--history``, else
``$OGACQ_HISTORY``, else ``history.sqlite`` in ogacq's data folder
(``ogacq.history.location``). A history that was named and cannot be read is an
error (exit 3); no default history yet means no earlier calibration is known, and
the record says so.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ogacq.errors import InputError
from ogacq.logs import logger
from ogacq.record.context import calibration_context
from ogacq.record.identity import session_record_id
from ogacq.session.store import LoadedSession

log = logger("ogacq.history")


def earlier_calibrations(option: str | None, session: LoadedSession,
                         ) -> tuple[list[dict[str, Any]] | None, str | None]:
    """(the machine's calibrations before this one, oldest first; or None and why
    none was read)."""
    from ogacq.history.location import DEFAULT_ORIGIN, history_for_session
    from ogacq.history.store import History

    try:
        location = history_for_session(option, Path(session.path))
    except InputError as exc:  # a URL that cannot be parsed: the report is made without it
        log.warning("no history plotted: %s", exc)
        return None, f"the history named cannot be used: {exc}"
    if location is None:
        return None, "the history is switched off (--history none)"
    if location.origin == DEFAULT_ORIGIN and location.path is not None \
            and not location.path.exists():
        return None, (f"no history database yet in ogacq's data folder "
                      f"({location.describe()}); --history names another")
    context = calibration_context(session)
    if context.machine_name is None:
        return None, "the session does not name its machine, so its history cannot be found"
    this_id = session_record_id(session)
    this_date = context.date.isoformat() if context.date else ""
    with History.open(location, create=False) as history:
        machine = history.machine(context.machine_name.strip(),
                                  (context.machine_serial or "").strip())
        if machine is None:
            return [], None  # known history, nothing of this machine in it yet
        entries = history.results_history(machine)
    return [e for e in entries
            if e["id"] != this_id and e["date"] and e["date"] <= this_date], None
