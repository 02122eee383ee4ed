"""The one rule for the dates ogacq reads: typed by a technician, given as an
option, written in a TOML file, recorded in a session or a record.

- A **date** is an ISO 8601 calendar date in its extended form, ``YYYY-MM-DD``
  (ISO 8601-1:2019 5.2.2.1), a day the Gregorian calendar has (``2026-02-30`` is not).
- A **moment** is a date (its midnight) or a date and a time of day,
  ``YYYY-MM-DDTHH:MM``, seconds and their decimal fraction optional, a space
  allowed for the ``T`` (RFC 3339 5.6 notes the same). Where the value may carry
  its UTC offset, ``Z``, ``+HH:MM`` or ``+HHMM`` may follow (the last is what
  ``time.strftime("%z")`` writes into session headers). Where it may not (a
  campaign's date, which is the shop's wall time, as ``now`` is taken), an offset
  is refused rather than silently dropped or mixed with local times.

Python's ``fromisoformat`` alone accepts far more (``20260110``, ``2026-W02``, a
time without a date): the grammar is checked here first, the calendar by
``datetime`` after it. Digits are ASCII only.

Two ways to read: strictly (:func:`parse_date`, :func:`parse_moment`), where a
person gave the value and a wrong one is a :class:`DateError` in one form,
``<file or option>: <key> = '<value>' is not <what>: <why> (<the rule>)``; and
leniently (:func:`date_or_none`, :func:`moment_or_none`), for documents ogacq
wrote itself, in which a value that does not follow the rule is unknown (None)
rather than a reason to refuse the whole session.
"""

from __future__ import annotations

import datetime
import re
import time
from pathlib import Path
from typing import Any

from ogacq.io.errors import InputError

_DATE = r"(?P<year>[0-9]{4})-(?P<month>[0-9]{2})-(?P<day>[0-9]{2})"
_TIME = (r"[T ](?P<hour>[0-9]{2}):(?P<minute>[0-9]{2})"
         r"(?::(?P<second>[0-9]{2})(?:\.(?P<fraction>[0-9]{1,6}))?)?")
_ZONE = r"(?P<zone>Z|[+-][0-9]{2}:?[0-9]{2})"
DATE_PATTERN = re.compile(_DATE)
MOMENT_PATTERN = re.compile(rf"{_DATE}(?:{_TIME}{_ZONE}?)?")

DATE_RULE = "a date is YYYY-MM-DD"
MOMENT_RULE = "a date and time is YYYY-MM-DD or YYYY-MM-DDTHH:MM[:SS]"
LOCAL_RULE = MOMENT_RULE + ", the shop's local time without a UTC offset"
ZONED_RULE = MOMENT_RULE + ", a UTC offset (Z, +HH:MM) optional"
_OFFSET_HERE = "it carries a UTC offset"


class DateError(InputError):
    """A date that does not follow the rule, said with where it was given (a file or
    an option, the line when known), its key and its value."""

    def __init__(self, source: str | Path | None, key: str, value: str, what: str, why: str,
                 rule: str, line: int | None = None) -> None:
        self.key = key
        self.value = value
        super().__init__(source, f"{key} = {value!r} is not {what}: {why} ({rule})", line)


def parse_date(text: str, *, source: str | Path | None, key: str,
               line: int | None = None) -> datetime.date:
    """``text`` as a calendar date; DateError naming ``source``, ``key`` and the value."""
    stripped = text.strip()
    if DATE_PATTERN.fullmatch(stripped) is None:
        raise DateError(source, key, text, "a date", _shape_problem(stripped, timed=False),
                        DATE_RULE, line)
    try:
        return datetime.date.fromisoformat(stripped)
    except ValueError as exc:  # the grammar holds, the calendar does not
        raise DateError(source, key, text, "a date", str(exc), DATE_RULE, line) from None


def parse_moment(text: str, *, source: str | Path | None, key: str, zone: bool,
                 line: int | None = None) -> datetime.datetime:
    """``text`` as a moment (a bare date: its midnight); ``zone``: whether a UTC offset
    may follow (then the result carries it), else one is refused."""
    stripped = text.strip()
    rule = ZONED_RULE if zone else LOCAL_RULE
    found = MOMENT_PATTERN.fullmatch(stripped)
    if found is None:
        raise DateError(source, key, text, "a date and time",
                        _shape_problem(stripped, timed=True), rule, line)
    if found["zone"] and not zone:
        raise DateError(source, key, text, "a date and time", _OFFSET_HERE, rule, line)
    try:
        return datetime.datetime.fromisoformat(stripped)
    except ValueError as exc:
        raise DateError(source, key, text, "a date and time", str(exc), rule, line) from None


def _shape_problem(text: str, *, timed: bool) -> str:
    """What is wrong with a value the grammar refuses, in words."""
    if not text:
        return "it is empty"
    if DATE_PATTERN.match(text) is None:
        return "it does not start with YYYY-MM-DD"
    rest = text[10:]
    if not timed:
        return f"{rest!r} follows the day"
    if re.fullmatch(_ZONE, rest):
        return "a UTC offset without a time of day"
    return f"{rest!r} after the day is not a time of day as THH:MM[:SS]"


def date_or_none(value: Any) -> datetime.date | None:
    """A recorded date (a ``date`` as is, a datetime's day, text by the rule); None for
    anything else."""
    if isinstance(value, datetime.datetime):
        return value.date()
    if isinstance(value, datetime.date):
        return value
    if not isinstance(value, str):
        return None
    try:
        return parse_date(value, source=None, key="date")
    except DateError:
        return None


def moment_or_none(value: Any) -> datetime.datetime | None:
    """A recorded moment (a datetime as is, a date's midnight, text by the rule with
    its offset if it has one); None for anything else."""
    if isinstance(value, datetime.datetime):
        return value
    if isinstance(value, datetime.date):
        return datetime.datetime.combine(value, datetime.time())
    if not isinstance(value, str):
        return None
    try:
        return parse_moment(value, source=None, key="date", zone=True)
    except DateError:
        return None


def wall_time(value: Any) -> datetime.datetime | None:
    """A recorded moment on the wall clock it was stated in (its offset dropped): the
    calibrations of one machine are ordered on one axis, not converted between zones."""
    moment = moment_or_none(value)
    return None if moment is None else moment.replace(tzinfo=None)


def local_moment(moment: datetime.datetime, *, source: str | Path | None, key: str,
                 line: int | None = None) -> datetime.datetime:
    """``moment`` (read as a TOML date-time, say) if it carries no UTC offset; else the
    DateError :func:`parse_moment` gives where no offset is allowed."""
    if moment.tzinfo is None:
        return moment
    raise DateError(source, key, moment.isoformat(), "a date and time", _OFFSET_HERE,
                    LOCAL_RULE, line)


TOML_RULE = ("TOML writes YYYY-MM-DD or YYYY-MM-DDTHH:MM:SS unquoted, a UTC offset as Z or "
             "+HH:MM")
_TOML_LINE = re.compile(r"\s*(?P<key>[A-Za-z0-9_.\"'-]+)\s*=\s*(?P<value>[0-9]{4}-[^#,}\]]*)")
# TOML v1.0.0, "Offset Date-Time" to "Local Date": RFC 3339's forms, the seconds required
_TOML_DATE = re.compile(rf"{_DATE}(?:[T ][0-9]{{2}}:[0-9]{{2}}:[0-9]{{2}}(?:\.[0-9]+)?"
                        r"(?:Z|[+-][0-9]{2}:[0-9]{2})?)?")
# what tomllib says of a date it cannot read (a wrong day; a shape it stops short in)
_TOML_DATE_COMPLAINTS = ("Invalid date or datetime", "Expected newline or end of document")


def toml_date_error(source: str | Path, complaint: str, line_text: str,
                    line: int) -> DateError | None:
    """Why the date on a TOML line is refused, when tomllib's ``complaint`` is only
    "Invalid date or datetime" or "Expected newline": the value against the rule, or
    what TOML asks more of it (the seconds, an offset's colon); None when the line
    holds no date or the complaint is about something else."""
    found = _TOML_LINE.match(line_text)
    if found is None or not any(c in complaint for c in _TOML_DATE_COMPLAINTS):
        return None
    key, value = found["key"].strip("\"'"), found["value"].strip()
    try:
        if DATE_PATTERN.fullmatch(value[:10]) and not value[10:].strip():
            parse_date(value, source=source, key=key, line=line)
        else:
            parse_moment(value, source=source, key=key, zone=True, line=line)
    except DateError as exc:
        return exc
    if _TOML_DATE.fullmatch(value):
        return None  # a date TOML reads: the complaint is about the rest of the line
    return DateError(source, key, value, "a TOML date", "TOML needs the seconds, and a "
                     "colon in a UTC offset", TOML_RULE, line)


def local_time_text(wall: Any) -> str:
    """A recorded wall-clock time (seconds since the epoch, as a session's records
    carry it) the way ogacq writes a time, local with its offset
    (``2026-01-10T09:00:00+0100``, as session headers are); ``?`` for no number."""
    if not isinstance(wall, int | float) or isinstance(wall, bool):
        return "?"
    return time.strftime("%Y-%m-%dT%H:%M:%S%z", time.localtime(wall))
