"""Which history database a command uses: the one place that decides it.

Order: the command's ``--history URL_OR_PATH``, else the ``OGACQ_HISTORY``
environment variable, else ``history.sqlite`` in ogacq's data folder
(``$OGACQ_HOME``, default ``~/.local/share/ogacq``: ``ogacq/io/data_folder.py``),
so that every run, demo and wizard of this account accumulates in one history
wherever it was started. ``none`` (or ``off``) in either place records nothing.

A value with ``://`` is a URL (``postgresql://user@host/db``,
``sqlite:////abs/path.sqlite``), read by SQLAlchemy's URL parser; anything else is the
path of an SQLite file (the default too: no URL, nothing of SQLAlchemy imported). A
PostgreSQL URL without a driver gets psycopg 3, the driver ogacq installs. A URL
that cannot be parsed (a port that is not a number, an unclosed ``[`` of an IPv6
host, a connection option or value libpq does not know) is an InputError naming
where it was given, its password hidden: a command whose history is optional
says it in a warning and goes on.
"""

from __future__ import annotations

import contextlib
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from ogacq.errors import InputError
from ogacq.io.data_folder import ENVIRONMENT_VARIABLE as DATA_VARIABLE
from ogacq.io.data_folder import data_folder

if TYPE_CHECKING:  # SQLAlchemy's URL is a PostgreSQL history's alone
    from sqlalchemy.engine import URL

ENVIRONMENT_VARIABLE = "OGACQ_HISTORY"
DEFAULT_FILE = "history.sqlite"
DISABLED = ("none", "off")


@dataclass(frozen=True)
class HistoryLocation:
    """An SQLite file (``path``) or a PostgreSQL database (``url``)."""

    origin: str  # where it was named: "--history", "OGACQ_HISTORY", "ogacq's data folder", ...
    path: Path | None = None
    url: URL | None = None

    @property
    def backend(self) -> str:
        return "sqlite" if self.path is not None else "postgresql"

    def describe(self) -> str:
        """The URL as it may be printed: the password hidden; an SQLite file by its path."""
        if self.path is not None:
            return str(self.path)
        assert self.url is not None
        return self.url.render_as_string(hide_password=True)


def parse_location(value: str, origin: str) -> HistoryLocation:
    """A ``--history`` value (or the environment's) as a location; InputError naming
    ``origin`` when it is neither a URL ogacq can use nor a path."""
    text = value.strip()
    if not text:
        raise InputError(origin, "is empty: give a database URL or an SQLite file's path")
    if "://" not in text:
        return HistoryLocation(origin, path=Path(text).expanduser().absolute())
    from sqlalchemy.engine import make_url
    from sqlalchemy.exc import ArgumentError

    try:
        url = make_url(text)
    except (ArgumentError, ValueError) as exc:
        raise InputError(origin, f"{hide_password(text)!r} is not a database URL "
                         f"({_why_unparsed(text, exc)}); write postgresql://USER@HOST[:PORT]/DB "
                         "or sqlite:////PATH") from None
    backend = url.get_backend_name()
    if backend in ("postgresql", "postgres"):
        driver = url.get_driver_name()
        if backend == "postgres" or driver in ("", "psycopg2"):
            url = url.set(drivername="postgresql+psycopg")
        problem = _postgresql_problem(url)
        if problem:
            raise InputError(origin, f"{hide_password(text)!r}: {problem}")
    elif backend == "sqlite":
        if not url.database or url.database == ":memory:":
            raise InputError(origin, "an SQLite history needs a file (sqlite:////PATH): one in "
                             "memory would be lost when the command ends")
        return HistoryLocation(origin, path=Path(url.database))  # as given, as it was said
    else:
        raise InputError(origin, f"database {backend!r} is not supported: ogacq keeps its "
                         "history in SQLite (a file) or PostgreSQL")
    return HistoryLocation(origin, url=url)


def hide_password(text: str) -> str:
    """A URL as it may be printed: the password between ``user:`` and ``@`` hidden."""
    return re.sub(r"(://[^:/@\s]*:)[^@]*@", r"\1***@", text)


def _why_unparsed(text: str, exc: Exception) -> str:
    netloc = text.split("://", 1)[1].split("/", 1)[0].rsplit("@", 1)[-1]
    if "[" in netloc and "]" not in netloc:
        return "the [ of an IPv6 host is not closed"
    if isinstance(exc, ValueError):
        return "its port is not a number"
    return "it does not read as one"


# libpq's connection options whose values are a choice or a number (PostgreSQL
# documentation, "libpq: Connection Strings, Parameter Key Words").
_PG_CHOICES = {
    "sslmode": ("disable", "allow", "prefer", "require", "verify-ca", "verify-full"),
    "gssencmode": ("disable", "prefer", "require"),
    "target_session_attrs": ("any", "read-write", "read-only", "primary", "standby",
                             "prefer-standby"),
}
_PG_NUMBERS = ("connect_timeout", "keepalives", "keepalives_idle", "keepalives_interval",
               "keepalives_count", "tcp_user_timeout")


def _postgresql_problem(url: URL) -> str | None:
    """What libpq would refuse in a PostgreSQL URL only when connecting, said now."""
    if url.port is not None and not 1 <= url.port <= 65535:
        return f"port {url.port} is not a TCP port (1..65535)"
    for key, value in url.query.items():
        values = value if isinstance(value, tuple) else (value,)
        if key in _PG_CHOICES and any(v not in _PG_CHOICES[key] for v in values):
            return f"{key} must be one of {', '.join(_PG_CHOICES[key])}, got {values[0]!r}"
        if key in _PG_NUMBERS and not all(re.fullmatch(r"[0-9]{1,9}", v) for v in values):
            return f"{key} must be a whole number of seconds, got {values[0]!r}"
    try:
        from psycopg.conninfo import make_conninfo
    except ImportError:  # the driver is missing: connecting will say so
        return None
    try:
        make_conninfo("", **{k: (v[0] if isinstance(v, tuple) else v)
                             for k, v in url.query.items()})
    except Exception as exc:  # psycopg.ProgrammingError: an option libpq does not know
        return f"{str(exc).splitlines()[0]} (libpq's connection options only)"
    return None


def _named(option: str | None) -> tuple[str, str] | None:
    """(value, origin) from the option, else the environment; None when neither."""
    if option is not None:
        return option, "--history"
    env = os.environ.get(ENVIRONMENT_VARIABLE)
    if env is not None and env.strip():
        return env, ENVIRONMENT_VARIABLE
    return None


DEFAULT_ORIGIN = "ogacq's data folder"


def default_location() -> HistoryLocation:
    """``history.sqlite`` in ogacq's data folder (created when first recorded into)."""
    return HistoryLocation(DEFAULT_ORIGIN, path=(data_folder() / DEFAULT_FILE).absolute())


def history_for_session(option: str | None, session_path: Path | None = None,
                        ) -> HistoryLocation | None:
    """The history a command working on a session records into (the same whichever
    session: ``session_path`` is kept for the callers' sake); None when recording
    is switched off."""
    if recording_off(option):
        return None
    named = _named(option)
    if named is None:
        location = default_location()
        assert location.path is not None
        _make_folder(location.path.parent)
        return location
    return parse_location(*named)


def recording_off(option: str | None) -> bool:
    """Whether the option, else the environment, switches the history off (``none``):
    known before anything of the history is imported."""
    named = _named(option)
    return named is not None and named[0].strip().lower() in DISABLED


def _make_folder(folder: Path) -> None:
    """ogacq's data folder made on first use, readable by its owner only (XDG Base
    Directory Specification 0.8: a missing destination directory is created with
    permissions 0700). A folder the history names is never made: a typo would be."""
    # a folder that cannot be made: opening the history says what is wrong, and the
    # command goes on
    with contextlib.suppress(OSError):
        folder.mkdir(mode=0o700, parents=True, exist_ok=True)


def history_to_read(option: str | None) -> HistoryLocation:
    """The history ``ogacq history`` reads: named, else the data folder's; InputError
    saying where it looked otherwise."""
    named = _named(option)
    if named is not None and named[0].strip().lower() not in DISABLED:
        return parse_location(*named)
    default = default_location()
    if default.path is not None and default.path.is_file():
        return default
    # named after the option only when it was given (`--history none`)
    raise InputError("--history" if option is not None else None,
                     f"no history yet in {default.describe()} (ogacq's data "
                     f"folder, ${DATA_VARIABLE}): nothing was recorded on this account; give "
                     f"--history URL_OR_PATH or set {ENVIRONMENT_VARIABLE} to read another")
