"""The history's connection: the standard library's ``sqlite3`` for an SQLite file,
psycopg 3 for PostgreSQL, behind one small interface, so that the store's SQL (written
once, with ``:name`` parameters, ``ogacq/history/store.py``) runs on either, and a
command recording into the default SQLite history imports no database library
beyond Python's own (SQLAlchemy's import was most of a short diagnosis's CPU).

- a JSON column's value is given as ``Json(value)`` and read back as the value
  (SQLite keeps its text, as SQLAlchemy's JSON type did: ``json.dumps``, and
  ``null`` for None; psycopg adapts and parses PostgreSQL's ``json`` itself);
- rows are read by column name (``row.record_id``) or position;
- a transaction that writes takes the database's write lock first: SQLite's
  ``BEGIN IMMEDIATE`` (a second station waits ``SQLITE_BUSY_TIMEOUT_S`` for it
  instead of failing half-way; SQLite's "BEGIN TRANSACTION" documentation),
  PostgreSQL's transaction-level advisory lock (its "Advisory Lock Functions");
- the connection is made on first use, so that a server that does not answer is
  said where the store guards its work, as any other database error.
"""

from __future__ import annotations

import contextlib
import json
import re
import sqlite3
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ogacq.history.schema import JSON_COLUMNS, quoted

if TYPE_CHECKING:
    from sqlalchemy.engine import URL

# A second station writing to the same SQLite file waits this long for its lock.
SQLITE_BUSY_TIMEOUT_S = 30.0
# PostgreSQL: a server that does not answer is said within this many seconds.
CONNECT_TIMEOUT_S = 10
# Any 64-bit number: the key of the advisory lock a PostgreSQL write takes.
WRITE_LOCK_KEY = 0x6F67_6171_6869_7374  # "ogaqhist"

_NAMED = re.compile(r"(?<![:\w]):(\w+)")


@dataclass(frozen=True)
class Json:
    """A value for a JSON column."""

    value: Any


class Row:
    """A result row, by column name or position."""

    __slots__ = ("_names", "_values")

    def __init__(self, names: Sequence[str], values: Sequence[Any]) -> None:
        self._names = tuple(names)
        self._values = tuple(values)

    def __getattr__(self, name: str) -> Any:
        try:
            return self._values[self._names.index(name)]
        except ValueError:
            raise AttributeError(name) from None

    def __getitem__(self, index: int | slice) -> Any:
        return self._values[index]

    def __iter__(self) -> Iterator[Any]:
        return iter(self._values)


def _sqlite_row(cursor: sqlite3.Cursor, values: tuple[Any, ...]) -> Row:
    names = [d[0] for d in cursor.description]
    return Row(names, [json.loads(v) if n in JSON_COLUMNS and isinstance(v, str) else v
                       for n, v in zip(names, values, strict=True)])


class Database:
    """One history database, connected on first use; ``errors``: what its driver raises."""

    def __init__(self, backend: str, connect: Callable[[], Any],
                 errors: tuple[type[Exception], ...], adapt_json: Callable[[Any], Any]) -> None:
        self.backend = backend
        self.errors = errors
        self._connect = connect
        self._adapt_json = adapt_json
        self._connection: Any = None

    @property
    def connection(self) -> Any:
        if self._connection is None:
            self._connection = self._connect()
        return self._connection

    def _params(self, params: Mapping[str, Any] | None) -> dict[str, Any]:
        return {k: self._adapt_json(v.value) if isinstance(v, Json) else v
                for k, v in (params or {}).items()}

    def _sql(self, sql: str) -> str:
        """``sql`` in the driver's parameter style: sqlite3 takes ``:name``, psycopg
        ``%(name)s`` (and a literal ``%`` doubled)."""
        if self.backend == "sqlite":
            return sql
        return _NAMED.sub(r"%(\1)s", sql.replace("%", "%%"))

    def rows(self, sql: str, params: Mapping[str, Any] | None = None) -> list[Row]:
        cursor = self.connection.execute(self._sql(sql), self._params(params))
        return list(cursor.fetchall()) if cursor.description else []

    def scalars(self, sql: str, params: Mapping[str, Any] | None = None) -> list[Any]:
        """The first column of every row."""
        return [row[0] for row in self.rows(sql, params)]

    def scalar(self, sql: str, params: Mapping[str, Any] | None = None) -> Any:
        """The first column of the one row, None when there is none."""
        found = self.scalars(sql, params)
        return found[0] if found else None

    def execute(self, sql: str, params: Mapping[str, Any] | None = None) -> None:
        self.connection.execute(self._sql(sql), self._params(params))

    def insert(self, table: str, rows: Sequence[Mapping[str, Any]]) -> None:
        """``rows`` (each with the same columns) into ``table``."""
        for row in rows:
            self.execute(f"INSERT INTO {table} ({', '.join(quoted(k) for k in row)}) "
                         f"VALUES ({', '.join(':' + k for k in row)})", row)

    def table_names(self) -> set[str]:
        """The tables of the database (PostgreSQL: of its current schema)."""
        if self.backend == "sqlite":
            return set(self.scalars("SELECT name FROM sqlite_master WHERE type = 'table' "
                                    "AND name NOT LIKE 'sqlite~_%' ESCAPE '~'"))
        return set(self.scalars("SELECT tablename FROM pg_catalog.pg_tables "
                                "WHERE schemaname = current_schema()"))

    @contextlib.contextmanager
    def transaction(self, *, write: bool) -> Iterator[Database]:
        """One transaction, committed when the block ends, rolled back when it raises."""
        conn = self.connection
        if self.backend == "postgresql":
            with conn.transaction():
                if write:  # one writer at a time per history (two stations' first records)
                    self.execute("SELECT pg_advisory_xact_lock(:key)", {"key": WRITE_LOCK_KEY})
                yield self
            return
        conn.execute("BEGIN IMMEDIATE" if write else "BEGIN")
        try:
            yield self
        except BaseException:
            if conn.in_transaction:
                conn.execute("ROLLBACK")
            raise
        conn.execute("COMMIT")

    def close(self) -> None:
        if self._connection is not None:
            self._connection.close()
            self._connection = None


def sqlite_database(path: Path) -> Database:
    def connect() -> sqlite3.Connection:
        # autocommit: the transactions are begun by ``Database.transaction``
        conn = sqlite3.connect(path, timeout=SQLITE_BUSY_TIMEOUT_S, isolation_level=None)
        conn.row_factory = _sqlite_row
        conn.execute("PRAGMA foreign_keys = ON")
        return conn

    return Database("sqlite", connect, (sqlite3.Error,), json.dumps)


def postgresql_database(url: URL) -> Database:
    # the dialect in use only: psycopg is imported for a PostgreSQL history alone
    import psycopg
    from psycopg.conninfo import make_conninfo
    from psycopg.types.json import Json as PgJson

    def connect() -> psycopg.Connection[Any]:
        # the URL's parts, then its options (``?host=/run/postgresql``, several hosts
        # joined as libpq lists them), as libpq's keywords: SQLAlchemy's psycopg dialect
        # gave them so; the timeout last, as its connect_args did
        options: dict[str, Any] = {"host": url.host, "port": url.port, "user": url.username,
                                   "password": url.password, "dbname": url.database}
        options.update({k: ",".join(v) if isinstance(v, tuple) else v
                        for k, v in url.query.items()})
        conninfo = make_conninfo("", **{**options, "connect_timeout": CONNECT_TIMEOUT_S})
        return psycopg.connect(conninfo, autocommit=True, row_factory=_pg_row)

    return Database("postgresql", connect, (psycopg.Error,), PgJson)


def _pg_row(cursor: Any) -> Any:
    names = [d.name for d in cursor.description or ()]
    return lambda values: Row(names, values)
