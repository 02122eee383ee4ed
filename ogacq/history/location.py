"""Which history database a command uses, and its SQLAlchemy URL.

Order: the command's ``--history URL_OR_PATH``, else the ``OGACQ_HISTORY``
environment variable, else ``history.sqlite`` beside the session the command
works on (``ogacq history`` has no session: it then looks for ``history.sqlite``
in the current folder). ``none`` (or ``off``) in either place records nothing.

A value with ``://`` is a URL (``postgresql://user@host/db``,
``sqlite:////abs/path.sqlite``); anything else is the path of an SQLite file. A
PostgreSQL URL without a driver gets psycopg 3, the driver ogacq installs.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from sqlalchemy.engine import URL, make_url
from sqlalchemy.exc import ArgumentError

from ogacq.errors import InputError

ENVIRONMENT_VARIABLE = "OGACQ_HISTORY"
DEFAULT_FILE = "history.sqlite"
DISABLED = ("none", "off")


@dataclass(frozen=True)
class HistoryLocation:
    url: URL
    origin: str  # where it was named: "--history", "OGACQ_HISTORY", "beside the session", ...

    @property
    def backend(self) -> str:
        return self.url.get_backend_name()

    def describe(self) -> str:
        """The URL as it may be printed: the password hidden; an SQLite file by its path."""
        if self.backend == "sqlite" and self.url.database:
            return self.url.database
        return self.url.render_as_string(hide_password=True)

    def option_value(self) -> str:
        """What to give ``--history`` to name this database again (the password hidden)."""
        return self.describe()


def parse_location(value: str, origin: str) -> HistoryLocation:
    """A ``--history`` value (or the environment's) as a location; InputError naming
    ``origin`` when it is neither a URL ogacq can use nor a path."""
    text = value.strip()
    if not text:
        raise InputError(origin, "is empty: give a database URL or an SQLite file's path")
    if "://" not in text:
        return HistoryLocation(URL.create("sqlite", database=str(Path(text).expanduser()
                                                                   .absolute())), origin)
    try:
        url = make_url(text)
    except ArgumentError:
        raise InputError(origin, f"{text!r} is not a database URL (postgresql://USER@HOST/DB or "
                         "sqlite:////PATH)") from None
    backend = url.get_backend_name()
    if backend in ("postgresql", "postgres"):
        driver = url.get_driver_name()
        if backend == "postgres" or driver in ("", "psycopg2"):
            url = url.set(drivername="postgresql+psycopg")
    elif backend == "sqlite":
        if not url.database or url.database == ":memory:":
            raise InputError(origin, "an SQLite history needs a file (sqlite:////PATH): one in "
                             "memory would be lost when the command ends")
    else:
        raise InputError(origin, f"database {backend!r} is not supported: ogacq keeps its "
                         "history in SQLite (a file) or PostgreSQL")
    return HistoryLocation(url, origin)


def _named(option: str | None) -> tuple[str, str] | None:
    """(value, origin) from the option, else the environment; None when neither."""
    if option is not None:
        return option, "--history"
    env = os.environ.get(ENVIRONMENT_VARIABLE)
    if env is not None and env.strip():
        return env, ENVIRONMENT_VARIABLE
    return None


def history_for_session(option: str | None, session_path: Path) -> HistoryLocation | None:
    """The history a command working on ``session_path`` records into; None when
    recording is switched off."""
    named = _named(option)
    if named is None:
        return HistoryLocation(URL.create("sqlite", database=str(
            session_path.absolute().parent / DEFAULT_FILE)), "beside the session")
    value, origin = named
    if value.strip().lower() in DISABLED:
        return None
    return parse_location(value, origin)


def history_to_read(option: str | None, folder: Path | None = None) -> HistoryLocation:
    """The history ``ogacq history`` reads: named, or ``history.sqlite`` in ``folder``
    (default: the current one); InputError saying how to name it otherwise."""
    named = _named(option)
    if named is not None and named[0].strip().lower() not in DISABLED:
        return parse_location(*named)
    candidate = (folder or Path.cwd()) / DEFAULT_FILE
    if candidate.is_file():
        return HistoryLocation(URL.create("sqlite", database=str(candidate.absolute())),
                               "the current folder")
    raise InputError("--history", f"no history named: give --history URL_OR_PATH, set "
                     f"{ENVIRONMENT_VARIABLE}, or run this in the folder holding {DEFAULT_FILE}")
