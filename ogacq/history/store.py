"""``History``: the one place that reads and writes the history database.

Recording is one transaction (the machine, the event, its parameters and
offsets states together, or nothing), and idempotent: every event has a unique
key (``entries.event_key``) and is inserted with ``ON CONFLICT DO NOTHING``, so
the same record sent twice, or by two stations at once, is one row. SQLite
transactions that write start with ``BEGIN IMMEDIATE`` (the file's write lock is
taken first, and a second station waits for it instead of failing half-way);
PostgreSQL serialises the first creation of the schema with an advisory lock.

Every database error becomes a ``HistoryError`` (a ``StorageError``: exit 3) in
one line naming the database and what could not be done. An SQLite history is
checked (``PRAGMA quick_check``, SQLite's "PRAGMA Statements" documentation)
before anything is written to it: one that fails, or whose schema cannot even be
read, is refused for writing with the way to repair it or to start another, so
nothing is recorded where it could never be read back.
"""

from __future__ import annotations

import contextlib
import json
import socket
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

from sqlalchemy import JSON, Connection, Engine, create_engine, event, func, inspect, select
from sqlalchemy.exc import SQLAlchemyError

from ogacq import __version__
from ogacq.errors import InputError, StorageError
from ogacq.history import schema as s
from ogacq.history.entries import (
    Calibration,
    Event,
    Machine,
    MapState,
    MapsWriteBack,
    OffsetState,
    Parameter,
    Recorded,
    WriteBack,
    check_record,
    clean_json,
    event_key,
    local_iso,
    machine_of,
    map_state_id,
    offsets_row,
    parameters_of,
    record_columns,
    state_id,
    utc_now,
)
from ogacq.history.location import HistoryLocation
from ogacq.model.gauges import AXES
from ogacq.record.calibration_record import CalibrationRecord

# A second station writing to the same SQLite file waits this long for its lock.
SQLITE_BUSY_TIMEOUT_S = 30.0
# PostgreSQL: a server that does not answer is said within this many seconds.
CONNECT_TIMEOUT_S = 10
# What to do with an SQLite history that fails its check: the sqlite3 shell's .recover
# (SQLite 3.29 and later) copies what can still be read into a new file.
REPAIR = ("repair it (`sqlite3 {path} .recover | sqlite3 REPAIRED.sqlite`, then "
          "--history REPAIRED.sqlite) or start another (--history NEW.sqlite)")

# Any 64-bit number: the key of the advisory lock taken while the schema is created.
SCHEMA_LOCK_KEY = 0x6F67_6171_6869_7374  # "ogaqhist"


class HistoryError(StorageError):
    """The history database cannot be reached, read or written, or is not an ogacq
    history (exit 3, like a disk that fails)."""

    def __init__(self, location: HistoryLocation, problem: str) -> None:
        self.location = location
        self.path = location.describe()
        Exception.__init__(self, f"history {self.path}: {problem}")


def _first_line(exc: BaseException) -> str:
    cause = getattr(exc, "orig", None) or exc
    text = " ".join(str(cause).split("\n")[0].split())
    return text or type(cause).__name__


class History:
    """An open history database. ``History.open(location)`` checks it (and creates
    the schema on first use unless ``create=False``); use it as a context manager."""

    def __init__(self, location: HistoryLocation, engine: Engine) -> None:
        self.location = location
        self.engine = engine
        self.version = s.SCHEMA_VERSION  # as opened: an older one read as it is

    # ------------------------------------------------------------------ opening
    @classmethod
    def open(cls, location: HistoryLocation, *, create: bool = True) -> History:
        """``create``: the history is opened to be written to (its schema made on first
        use, an SQLite file checked first)."""
        engine = _engine(location, create)
        history = cls(location, engine)
        try:
            if create and location.backend == "sqlite":
                history._check_sqlite()
            with history._guard("open"), history._transaction(write=create) as conn:
                history.version = _prepare(conn, location, create)
        except BaseException:
            engine.dispose()
            raise
        return history

    def _check_sqlite(self) -> None:
        """Refuse to write to an SQLite file that fails its integrity check (a new one
        has nothing to check; one that cannot be opened says why when it is)."""
        path = self.location.describe()
        if not Path(path).is_file() or not Path(path).stat().st_size:
            return
        try:
            with self.engine.connect() as conn:
                found = [row[0] for row in conn.exec_driver_sql("PRAGMA quick_check")]
        except ValueError:  # the check's own report names damaged text
            found = ["its report is not even text"]
        except SQLAlchemyError as exc:
            import sqlite3  # an SQLite history's only: here, the dialect in use loaded it

            if isinstance(getattr(exc, "orig", None), sqlite3.OperationalError):
                raise HistoryError(self.location, f"cannot open ({_first_line(exc)})") from None
            raise HistoryError(self.location, f"cannot be read ({_first_line(exc)}): nothing is "
                               f"recorded into it; {REPAIR.format(path=path)}") from None
        if found != ["ok"]:
            first = " ".join(str(found[0]).split()) if found else "no answer"
            raise HistoryError(self.location, f"fails its integrity check ({first}): nothing is "
                               f"recorded into it; {REPAIR.format(path=path)}")
        damaged = self._damaged_record()
        if damaged:
            raise HistoryError(self.location, f"{damaged}: nothing is recorded into it (it could "
                               f"not be read back); {REPAIR.format(path=path)}")

    def _damaged_record(self) -> str | None:
        """The first stored JSON document that no longer reads (a flipped byte the page
        checks cannot see), or None. Every record is read: a history holds a few
        hundred of them."""
        e = s.events
        columns = [c.name for c in e.columns if isinstance(c.type, JSON)]
        where = "its events"
        try:
            with self.engine.connect() as conn:
                if e.name not in inspect(conn).get_table_names():
                    return None
                rows = conn.exec_driver_sql(f"SELECT id, {', '.join(columns)} FROM {e.name}")
                for row in rows:
                    for column, text in zip(columns, row[1:], strict=True):
                        where = f"event {row[0]}, {column}"
                        if text is not None:
                            json.loads(text)
        except (SQLAlchemyError, ValueError) as exc:
            return f"a stored record is damaged ({where}: {_first_line(exc)})"
        return None

    def close(self) -> None:
        self.engine.dispose()

    def __enter__(self) -> History:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @contextlib.contextmanager
    def _guard(self, what: str) -> Iterator[None]:
        try:
            yield
        except SQLAlchemyError as exc:
            raise HistoryError(self.location, f"cannot {what} ({_first_line(exc)})") from None
        except ValueError as exc:  # a stored JSON document damaged (its text, its UTF-8)
            raise HistoryError(self.location, f"cannot {what}: a stored record is damaged "
                               f"({_first_line(exc)})") from None

    @contextlib.contextmanager
    def _transaction(self, *, write: bool) -> Iterator[Connection]:
        with self.engine.connect() as conn:
            if write:
                conn.info["ogacq_immediate"] = True  # SQLite: BEGIN IMMEDIATE
            with conn.begin():
                if write and conn.dialect.name == "postgresql":
                    # one writer at a time per history: two stations recording the same
                    # machine's first calibration must not both insert it
                    conn.execute(select(func.pg_advisory_xact_lock(SCHEMA_LOCK_KEY)))
                yield conn

    # ------------------------------------------------------------------ recording
    # ``session_path``: where the session is, as an absolute path, when the record
    # names it relative to the folder its command ran in.
    def record_calibration(self, record: Mapping[str, Any], *,
                           session_path: str | None = None) -> Recorded:
        record = check_record(record)
        return self._record("calibration", record, details=None, parameters=True,
                            session_path=session_path)

    def record_diagnosis(self, record: Mapping[str, Any], diagnosis: Mapping[str, Any], *,
                         session_path: str | None = None) -> Recorded:
        record = check_record(record)
        return self._record("diagnosis", record, details=clean_json(dict(diagnosis)),
                            parameters=False, session_path=session_path)

    def record_writeback(self, record: Mapping[str, Any], writeback: WriteBack, *,
                         session_path: str | None = None) -> Recorded:
        """A write-back or restore, with the offsets it found and left as states."""
        record = check_record(record)
        details = clean_json({"operation": writeback.operation, "action": writeback.action,
                              "status": writeback.status, "old_mm": dict(writeback.old_mm),
                              "new_mm": dict(writeback.new_mm), "profile": writeback.profile,
                              "restores": writeback.restores})
        return self._record(writeback.kind, record, details=details, parameters=False,
                            writeback=writeback, session_path=session_path)

    def record_maps_writeback(self, record: Mapping[str, Any], writeback: MapsWriteBack, *,
                              session_path: str | None = None) -> Recorded:
        """A maps write or restore, with the maps it found and left as states."""
        record = check_record(record)
        details = clean_json({"operation": writeback.operation, "action": writeback.action,
                              "status": writeback.status, "maps_file": writeback.maps_file,
                              "old_checksum": writeback.old_checksum,
                              "new_checksum": writeback.new_checksum,
                              "restores": writeback.restores})
        return self._record(writeback.kind, record, details=details, parameters=False,
                            maps=writeback, session_path=session_path)

    def record_calibrate(self, record: Mapping[str, Any], procedure: str,
                         details: Mapping[str, Any], *,
                         session_path: str | None = None) -> Recorded:
        """One ``ogacq calibrate`` procedure's outcome (validated, restored and why),
        naming the write-backs it made."""
        record = check_record(record)
        return self._record("calibrate", record, details=clean_json(dict(details)),
                            parameters=False, session_path=session_path, operation=procedure)

    def _record(self, kind: str, record: dict[str, Any], *, details: dict[str, Any] | None,
                parameters: bool, writeback: WriteBack | None = None,
                maps: MapsWriteBack | None = None, session_path: str | None = None,
                operation: str | None = None) -> Recorded:
        operation = (writeback.operation if writeback else maps.operation if maps
                     else operation)
        key = event_key(kind, record["id"], operation)
        columns = record_columns(record)
        if session_path is not None:
            columns["session_path"] = session_path
        wall = writeback.wall if writeback else maps.wall if maps else None
        if wall is not None:
            columns["campaign_date"] = local_iso(wall) or columns["campaign_date"]
        with self._guard(f"record {key}"), self._transaction(write=True) as conn:
            machine_id = _machine_id(conn, machine_of(record))
            inserted = conn.execute(_insert(conn, s.events).values(
                event_key=key, machine_id=machine_id, kind=kind, recorded_at=utc_now(),
                station=socket.gethostname(), details=details,
                record=clean_json(record), **{**columns, "software":
                                              columns["software"] or f"ogacq {__version__}"})
                .on_conflict_do_nothing(index_elements=["event_key"])
                .returning(s.events.c.id))
            event_id = inserted.scalar_one_or_none()
            if event_id is None:  # recorded before (here or by another station)
                write = writeback if writeback is not None else maps
                if write is not None:
                    _found_done(conn, key, write)
                return Recorded(present=[key])
            if parameters:
                rows = [{"event_id": event_id, "name": p.name, "value_mm": p.value_mm,
                         "u_mm": p.u_mm, "expanded_mm": p.expanded_mm, "k": p.k,
                         "std_mm": p.std_mm}
                        for p in parameters_of(record)]
                if rows:
                    conn.execute(s.parameters.insert(), rows)
            if writeback is not None:
                conn.execute(s.offset_states.insert(),
                             _state_rows(writeback, machine_of(record), event_id, machine_id))
            if maps is not None:
                conn.execute(s.map_states.insert(),
                             _map_state_rows(maps, machine_of(record), event_id, machine_id))
        return Recorded(new=[key])

    # ------------------------------------------------------------------ reading
    def present(self, keys: list[str]) -> list[str]:
        """Those of the event ``keys`` (``entries.event_key``) already recorded."""
        e = s.events
        with self._guard("read the events"), self._transaction(write=False) as conn:
            found = set(conn.execute(select(e.c.event_key)
                                     .where(e.c.event_key.in_(keys))).scalars())
        return [key for key in keys if key in found]

    def records_seen(self, record_id: str) -> int | None:
        """The most records the history saw in the session of ``record_id`` (its events'
        records count them): a session file holding fewer lost its tail. None when the
        history holds nothing of it."""
        e = s.events
        with self._guard("read the events"), self._transaction(write=False) as conn:
            records = conn.execute(select(e.c.record).where(e.c.record_id == record_id)).scalars()
            counts = [CalibrationRecord.from_json(r).session_file.records for r in records
                      if isinstance(r, dict)]
        seen = [count for count in counts if count is not None]
        return max(seen) if seen else None

    def machines(self) -> list[Machine]:
        with self._guard("read the machines"), self._transaction(write=False) as conn:
            rows = conn.execute(select(s.machines).order_by(s.machines.c.name,
                                                            s.machines.c.serial)).all()
        return [Machine(r.id, r.name, r.serial) for r in rows]

    def find_machine(self, typed: str) -> Machine:
        """The one machine ``typed`` names (``find_machines``); InputError naming the
        machines the history holds, or those the name fits, each as it can be typed."""
        found = self.find_machines(typed)
        if len(found) == 1:
            return found[0]
        if found:
            raise InputError(typed, f"names {len(found)} machines: "
                             f"{', '.join(repr(m.label) for m in found)}; give one of "
                             f"these (`ogacq history {found[0].label!r}`)")
        there = ", ".join(m.label for m in self.machines()) or "none yet"
        raise InputError(typed, f"no such machine in history "
                         f"{self.location.describe()} (machines: {there})")

    def find_machines(self, typed: str) -> list[Machine]:
        """The machines a person means by ``typed``: its label as ``ogacq history``
        prints it ("NAME (serial SERIAL)", "NAME (no serial)"), else its serial, else
        every machine of that name."""
        wanted = typed.strip()
        known = self.machines()
        return ([m for m in known if m.label == wanted]
                or [m for m in known if m.serial and m.serial == wanted]
                or [m for m in known if m.name == wanted])

    def machine(self, name: str, serial: str) -> Machine | None:
        """The machine of exactly that identity (a record's), if the history has it."""
        return next((m for m in self.machines() if (m.name, m.serial) == (name, serial)),
                    None)

    def calibrations(self, machine: Machine) -> list[Calibration]:
        """The machine's calibrations, oldest first (by their campaign date)."""
        e = s.events
        with self._guard("read the calibrations"), self._transaction(write=False) as conn:
            rows = conn.execute(select(e).where(e.c.machine_id == machine.id,
                                                e.c.kind == "calibration")).all()
            params = conn.execute(select(s.parameters).where(
                s.parameters.c.event_id.in_([r.id for r in rows]))).all() if rows else []
        by_event: dict[int, dict[str, Parameter]] = {}
        for p in params:
            by_event.setdefault(p.event_id, {})[p.name] = Parameter(
                p.name, p.value_mm, p.u_mm, p.expanded_mm, p.k, p.std_mm)
        out = []
        for r in rows:
            record = CalibrationRecord.from_json(r.record if isinstance(r.record, dict) else {})
            out.append(Calibration(
                r.record_id, r.campaign_date, r.operator, r.verdict, r.acceptance_decision,
                r.acceptance, r.ambient_c, _in_record_order(by_event.get(r.id, {}), r.record),
                r.session_path, r.session_sha256, r.instruments, r.environment, r.overrides,
                r.station, record.simulated, record.offsets_in_force_mm))
        return sorted(out, key=lambda c: (c.date or "", c.record_id))

    def events(self, machine: Machine) -> list[Event]:
        """Every event of the machine (calibrations, diagnoses, write-backs, restores),
        by date."""
        e = s.events
        with self._guard("read the events"), self._transaction(write=False) as conn:
            rows = conn.execute(select(e.c.kind, e.c.record_id, e.c.campaign_date,
                                       e.c.operator, e.c.session_path, e.c.details)
                                .where(e.c.machine_id == machine.id)).all()
        return sorted((Event(r.kind, r.record_id, r.campaign_date, r.operator, r.session_path,
                             r.details) for r in rows),
                      key=lambda v: (v.date or "", s.EVENT_KINDS.index(v.kind), v.record_id))

    def records(self, machine: Machine, record_id: str) -> dict[str, Any] | None:
        """The record stored whole with the machine's calibration ``record_id``."""
        e = s.events
        with self._guard("read a record"), self._transaction(write=False) as conn:
            return conn.execute(select(e.c.record).where(
                e.c.machine_id == machine.id, e.c.record_id == record_id,
                e.c.kind == "calibration")).scalar_one_or_none()

    def results_history(self, machine: Machine) -> list[dict[str, Any]]:
        """The machine's calibrations as ``build_record(history=...)`` takes them
        (docs/calibration-record.md section 5): ``{"id", "date", "results"}`` each,
        the results as their records hold them, oldest first."""
        e = s.events
        with self._guard("read the calibrations"), self._transaction(write=False) as conn:
            rows = conn.execute(select(e.c.record_id, e.c.campaign_date, e.c.record).where(
                e.c.machine_id == machine.id, e.c.kind == "calibration")).all()
        entries = [{"id": r.record_id, "date": r.campaign_date,
                    "results": CalibrationRecord.from_json(
                        r.record if isinstance(r.record, dict) else {}).results or {}}
                   for r in rows]
        return sorted(entries, key=lambda v: (v["date"] or "", v["id"]))

    def states(self, machine: Machine) -> list[OffsetState]:
        """The offsets states of the machine's write-backs and restores, oldest first."""
        o, e = s.offset_states, s.events
        with self._guard("read the offsets states"), self._transaction(write=False) as conn:
            rows = conn.execute(select(o, e.c.record_id, e.c.session_path)
                                .join(e, e.c.id == o.c.event_id)
                                .where(o.c.machine_id == machine.id)).all()
        states = [OffsetState(r.state_id, r.stage, r.at, r.wall, r.operation, r.action,
                              r.status, r.profile,
                              {a: getattr(r, f"{a}_mm") for a in AXES},
                              r.record_id, r.session_path) for r in rows]
        return sorted(states, key=lambda v: (v.wall or 0.0, v.stage != "before", v.state_id))

    def map_states(self, machine: Machine) -> list[MapState]:
        """The maps states of the machine's maps writes and restores, oldest first
        (none in a history of schema 1, which had none)."""
        if self.version < 2:
            return []
        m, e = s.map_states, s.events
        with self._guard("read the maps states"), self._transaction(write=False) as conn:
            rows = conn.execute(select(m, e.c.record_id, e.c.session_path)
                                .join(e, e.c.id == m.c.event_id)
                                .where(m.c.machine_id == machine.id)).all()
        states = [MapState(r.state_id, r.stage, r.at, r.wall, r.operation, r.action, r.status,
                           r.maps_file, r.checksum, list(r.maps or []), r.record_id,
                           r.session_path) for r in rows]
        return sorted(states, key=lambda v: (v.wall or 0.0, v.stage != "before", v.state_id))

    def calibrate_events(self, machine: Machine) -> list[Event]:
        """The machine's ``ogacq calibrate`` procedures, by date."""
        return [v for v in self.events(machine) if v.kind == "calibrate"]

    def current_state(self, machine: Machine) -> OffsetState | None:
        """What the history says the controller holds: the last write-back or restore
        that finished."""
        done = [v for v in self.states(machine) if v.stage == "after" and v.status == "done"]
        return done[-1] if done else None

    def find_state(self, machine: Machine, wanted: str) -> OffsetState:
        """An offsets state by its id, or the offsets a calibration's last finished
        write-back wrote (by the calibration's record id)."""
        states = self.states(machine)
        by_id = [v for v in states if v.state_id == wanted.strip()]
        if by_id:
            return by_id[0]
        written = [v for v in states if v.record_id == wanted.strip() and v.stage == "after"
                   and v.status == "done" and v.action == "write"]
        if written:
            return written[-1]
        if any(c.record_id == wanted.strip() for c in self.calibrations(machine)):
            raise InputError(wanted, f"calibration {wanted} of {machine.describe()} was never "
                             "written to a controller: nothing of it to restore (`ogacq offsets "
                             "write SESSION` writes it)")
        raise InputError(wanted, f"no offsets state or calibration {wanted} for "
                         f"{machine.describe()} (`ogacq history {machine.label!r} --states` "
                         "lists them)")


def _in_record_order(found: dict[str, Parameter], record: Any) -> dict[str, Parameter]:
    order = [p.name for p in parameters_of(record)] if isinstance(record, Mapping) else []
    return {n: found[n] for n in [*order, *sorted(set(found) - set(order))] if n in found}


def _state_rows(writeback: WriteBack, machine: tuple[str, str], event_id: int,
                machine_id: int) -> list[dict[str, Any]]:
    common = {"event_id": event_id, "machine_id": machine_id, "at": local_iso(writeback.wall),
              "wall": writeback.wall, "operation": writeback.operation,
              "action": writeback.action, "status": writeback.status,
              "profile": writeback.profile}
    return [{**common, "state_id": state_id(machine, writeback.operation, stage), "stage": stage,
             **offsets_row(values)}
            for stage, values in (("before", writeback.old_mm), ("after", writeback.new_mm))]


def _map_state_rows(maps: MapsWriteBack, machine: tuple[str, str], event_id: int,
                    machine_id: int) -> list[dict[str, Any]]:
    common = {"event_id": event_id, "machine_id": machine_id, "at": local_iso(maps.wall),
              "wall": maps.wall, "operation": maps.operation, "action": maps.action,
              "status": maps.status, "maps_file": maps.maps_file}
    return [{**common, "state_id": map_state_id(machine, maps.operation, stage),
             "stage": stage, "checksum": checksum, "maps": clean_json([dict(m) for m in values])}
            for stage, checksum, values in (("before", maps.old_checksum, maps.old_maps),
                                            ("after", maps.new_checksum, maps.new_maps))]


def _found_done(conn: Connection, key: str, write: WriteBack | MapsWriteBack) -> None:
    """A write recorded as failed or interrupted (a Ctrl-C, a kill before its outcome)
    and recorded again as done, once read back in force by a resumed procedure: the
    history says what the machine holds, not the first word it was given."""
    if write.status != "done":
        return
    e = s.events
    row = conn.execute(select(e.c.id, e.c.details).where(e.c.event_key == key)).one()
    details = dict(row.details or {})
    if details.get("status") == "done":
        return
    conn.execute(e.update().where(e.c.id == row.id).values(details={**details,
                                                                    "status": "done"}))
    states = s.offset_states if isinstance(write, WriteBack) else s.map_states
    conn.execute(states.update().where(states.c.event_id == row.id).values(status="done"))


def _insert(conn: Connection, table: s.Table) -> Any:
    """The dialect's INSERT, which has ON CONFLICT DO NOTHING on both backends."""
    # only the dialect in use is imported (a history in SQLite loads no PostgreSQL code)
    if conn.dialect.name == "postgresql":
        from sqlalchemy.dialects import postgresql

        return postgresql.insert(table)
    from sqlalchemy.dialects import sqlite

    return sqlite.insert(table)


def _machine_id(conn: Connection, identity: tuple[str, str]) -> int:
    name, serial = identity
    m = s.machines
    conn.execute(_insert(conn, m).values(name=name, serial=serial, first_recorded=utc_now())
                 .on_conflict_do_nothing(index_elements=["name", "serial"]))
    return conn.execute(select(m.c.id).where(m.c.name == name, m.c.serial == serial)
                        ).scalar_one()


def _engine(location: HistoryLocation, create: bool) -> Engine:
    url = location.url
    if location.backend == "sqlite":
        path = Path(url.database or "")
        if not path.parent.is_dir():
            raise HistoryError(location, f"cannot open: there is no folder {path.parent}")
        if not create and not path.exists():
            raise HistoryError(location, "no history here (the file does not exist)")
        if path.exists() and not path.is_file():
            raise HistoryError(location, "is not a file")
        engine = create_engine(url, connect_args={"timeout": SQLITE_BUSY_TIMEOUT_S})

        @event.listens_for(engine, "connect")
        def _connect(dbapi_connection: Any, _record: Any) -> None:
            # the transactions are begun below, not by the driver (SQLAlchemy 2.0 docs,
            # pysqlite dialect, "Serializable isolation / Savepoints / Transactional DDL")
            dbapi_connection.isolation_level = None
            dbapi_connection.execute("PRAGMA foreign_keys = ON")

        @event.listens_for(engine, "begin")
        def _begin(conn: Connection) -> None:
            immediate = conn.info.pop("ogacq_immediate", False)
            conn.exec_driver_sql("BEGIN IMMEDIATE" if immediate else "BEGIN")

        return engine
    return create_engine(url, connect_args={"connect_timeout": CONNECT_TIMEOUT_S},
                         pool_pre_ping=True)


def _prepare(conn: Connection, location: HistoryLocation, create: bool) -> int:
    """Check that the database is an ogacq history this version reads; create the
    schema in an empty one (when ``create``); migrate an older one (when ``create``:
    one opened to read is read as its schema stands). Returns the schema version."""
    tables = set(inspect(conn).get_table_names())
    if s.schema_info.name not in tables:
        if tables:
            listed = ", ".join(sorted(tables)[:5]) + (", ..." if len(tables) > 5 else "")
            raise HistoryError(location, f"is not an ogacq history: it holds other tables "
                               f"({listed}); give an empty database or an ogacq history")
        if not create:
            raise HistoryError(location, "holds no ogacq history yet (nothing was recorded)")
        s.metadata.create_all(conn)
        conn.execute(s.schema_info.insert(), [
            {"key": "application", "value": s.APPLICATION},
            {"key": "version", "value": str(s.SCHEMA_VERSION)},
            {"key": "created", "value": utc_now()},
            {"key": "created_by", "value": f"ogacq {__version__}"}])
        return s.SCHEMA_VERSION
    info: dict[str, str] = {row.key: row.value for row in conn.execute(
        select(s.schema_info.c.key, s.schema_info.c.value))}
    if info.get("application") != s.APPLICATION:
        raise HistoryError(location, "is not an ogacq history (its ogacq_schema table says "
                           f"{info.get('application')!r})")
    try:
        version = int(info.get("version", ""))
    except ValueError:
        raise HistoryError(location, f"has an unreadable schema version "
                           f"{info.get('version')!r}") from None
    if version > s.SCHEMA_VERSION:
        raise HistoryError(location, f"was written by a newer ogacq (schema {version}; this "
                           f"one reads up to {s.SCHEMA_VERSION}): update ogacq")
    if version < s.SCHEMA_VERSION:
        if not create:  # read as it is: what a later schema added is simply not there
            return version
        for step in range(version, s.SCHEMA_VERSION):
            for statement in s.MIGRATIONS[step]:
                if callable(statement):
                    statement(conn)
                else:
                    conn.exec_driver_sql(statement)
        conn.execute(s.schema_info.update().where(s.schema_info.c.key == "version")
                     .values(value=str(s.SCHEMA_VERSION)))
    return s.SCHEMA_VERSION
