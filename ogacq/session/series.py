"""The sessions of one campaign file run again and again: ``session.jsonl``, then
``session-2.jsonl``, ``session-3.jsonl`` beside it (a validation run after a
write-back, a check a month later).

``ogacq run`` records into the campaign's session while it does not exist; once
it holds a complete campaign, into the next free number of the series (said on
the terminal). A session of the series that has not finished is resumed, not
passed over: a new run is refused naming it, as before.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from ogacq.errors import OgacqError
from ogacq.io.errors import InputError
from ogacq.session.state import RUNNING, completeness
from ogacq.session.store import load_session

_NUMBERED = re.compile(r"^(?P<stem>.+)-(?P<n>[1-9][0-9]*)$")


def numbered(base: Path, n: int) -> Path:
    """The ``n``-th session of the series of ``base`` (the first is ``base`` itself)."""
    return base if n == 1 else base.with_name(f"{base.stem}-{n}{base.suffix}")


@dataclass(frozen=True)
class NextSession:
    path: Path  # where the new run records
    previous: Path | None  # the complete session before it (None: the series' first)


def next_session(base: Path) -> NextSession:
    """Where a new run of the campaign whose session is ``base`` records: ``base`` when
    it does not exist, else the next free number after a complete session. InputError
    when the last session of the series has not finished (resume it) or cannot be
    read."""
    n = 1
    while numbered(base, n + 1).exists():
        n += 1
    last = numbered(base, n)
    if not last.exists():
        return NextSession(base, None)
    try:
        state = completeness(load_session(last))
    except OgacqError as exc:
        raise InputError(last, f"a session already exists here and cannot be read ({exc}); "
                         "name the new one with --session FILE") from None
    if state.status == RUNNING:
        raise InputError(last, f"a session already exists here and its campaign is running "
                         f"({state.holder}): wait until it has finished")
    if not state.complete:
        raise InputError(last, "a session already exists here and its campaign has not "
                         f"finished: resume it with `ogacq resume {last}`, or name another "
                         "with --session FILE")
    return NextSession(numbered(base, n + 1), last)


def earlier_in_series(path: Path) -> list[Path]:
    """The sessions before ``path`` in its series, latest first (``session-3.jsonl``:
    ``session-2.jsonl``, ``session.jsonl``); none for a session that is not numbered
    or whose first session is not beside it."""
    match = _NUMBERED.match(path.stem)
    if match is None:
        return []
    base = path.with_name(match["stem"] + path.suffix)
    if not base.exists():
        return []
    return [p for p in (numbered(base, k) for k in range(int(match["n"]) - 1, 0, -1))
            if p.exists()]
