"""``History``: the one place that reads and writes the history database.

Recording is one transaction (the machine, the event, its parameters and
offsets states together, or nothing), and idempotent: every event has a unique
key (``entries.event_key``) and is inserted with ``ON CONFLICT DO NOTHING``, so
the same record sent twice, or by two stations at once, is one row. SQLite
transactions that write start with ``BEGIN IMMEDIATE`` (the file's write lock is
taken first, and a second station waits for it instead of failing half-way);
PostgreSQL serialises the first creation of the schema with an advisory lock.

The SQL is written once, run on either backend by ``ogacq.history.database`` (the
standard library's sqlite3, or psycopg for PostgreSQL). Every database error becomes
a ``HistoryError`` (a ``StorageError``: exit 3) in
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
import sqlite3
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

from ogacq import __version__
from ogacq.errors import InputError, StorageError
from ogacq.history import schema as s
from ogacq.history.database import Database, Json, postgresql_database, sqlite_database
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
    typed_record,
    utc_now,
)
from ogacq.history.location import HistoryLocation
from ogacq.model.gauges import AXES

# What to do with an SQLite history that fails its check: the sqlite3 shell's .recover
# (SQLite 3.29 and later) copies what can still be read into a new file.
REPAIR = ("repair it (`sqlite3 {path} .recover | sqlite3 REPAIRED.sqlite`, then "
          "--history REPAIRED.sqlite) or start another (--history NEW.sqlite)")


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

    def __init__(self, location: HistoryLocation, db: Database) -> None:
        self.location = location
        self.db = db
        self.version = s.SCHEMA_VERSION  # as opened: an older one read as it is

    # ------------------------------------------------------------------ opening
    @classmethod
    def open(cls, location: HistoryLocation, *, create: bool = True) -> History:
        """``create``: the history is opened to be written to (its schema made on first
        use, an SQLite file checked first)."""
        history = cls(location, _database(location, create))
        try:
            if create and location.backend == "sqlite":
                history._check_sqlite()
            with history._guard("open"), history.db.transaction(write=create) as db:
                history.version = _prepare(db, location, create)
        except BaseException:
            history.close()
            raise
        return history

    def _check_sqlite(self) -> None:
        """Refuse to write to an SQLite file that fails its integrity check (a new one
        has nothing to check; one that cannot be opened says why when it is)."""
        path = self.location.describe()
        if not Path(path).is_file() or not Path(path).stat().st_size:
            return
        try:
            found = self.db.scalars("PRAGMA quick_check")
        except ValueError:  # the check's own report names damaged text
            found = ["its report is not even text"]
        except sqlite3.Error as exc:
            if isinstance(exc, sqlite3.OperationalError):
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
        columns = e.json_columns
        where = "its events"
        try:
            if e.name not in self.db.table_names():
                return None
            # as text (named otherwise than the JSON columns, which are read as documents)
            rows = self.db.rows(f"SELECT id, {', '.join(f'{c} AS {c}_text' for c in columns)} "
                                f"FROM {e.name}")
            for row in rows:
                for column, text in zip(columns, row[1:], strict=True):
                    where = f"event {row[0]}, {column}"
                    if isinstance(text, str):
                        json.loads(text)
        except self.db.errors + (ValueError,) as exc:
            return f"a stored record is damaged ({where}: {_first_line(exc)})"
        return None

    def close(self) -> None:
        self.db.close()

    def __enter__(self) -> History:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @contextlib.contextmanager
    def _guard(self, what: str) -> Iterator[None]:
        try:
            yield
        except self.db.errors as exc:
            raise HistoryError(self.location, f"cannot {what} ({_first_line(exc)})") from None
        except ValueError as exc:  # a stored JSON document damaged (its text, its UTF-8)
            raise HistoryError(self.location, f"cannot {what}: a stored record is damaged "
                               f"({_first_line(exc)})") from None

    # ------------------------------------------------------------------ recording
    # ``session_path``: where the session is, as an absolute path, when the record
    # names it relative to the folder its command ran in.
    def record_calibration(self, record: Mapping[str, Any], *,
                           session_path: str | None = None) -> Recorded:
        return self._record("calibration", record, details=None, parameters=True,
                            session_path=session_path)

    def record_diagnosis(self, record: Mapping[str, Any], diagnosis: Mapping[str, Any], *,
                         session_path: str | None = None) -> Recorded:
        return self._record("diagnosis", record, details=clean_json(dict(diagnosis)),
                            parameters=False, session_path=session_path)

    def record_writeback(self, record: Mapping[str, Any], writeback: WriteBack, *,
                         session_path: str | None = None) -> Recorded:
        """A write-back or restore, with the offsets it found and left as states."""
        details = _fields(writeback, "old_mm", "new_mm", "profile", "restores")
        return self._record(writeback.kind, record, details=details, parameters=False,
                            writeback=writeback, session_path=session_path)

    def record_maps_writeback(self, record: Mapping[str, Any], writeback: MapsWriteBack, *,
                              session_path: str | None = None) -> Recorded:
        """A maps write or restore, with the maps it found and left as states."""
        details = _fields(writeback, "maps_file", "old_checksum", "new_checksum", "restores")
        return self._record(writeback.kind, record, details=details, parameters=False,
                            maps=writeback, session_path=session_path)

    def record_calibrate(self, record: Mapping[str, Any], procedure: str,
                         details: Mapping[str, Any], *,
                         session_path: str | None = None) -> Recorded:
        """One ``ogacq calibrate`` procedure's outcome (validated, restored and why),
        naming the write-backs it made."""
        return self._record("calibrate", record, details=clean_json(dict(details)),
                            parameters=False, session_path=session_path, operation=procedure)

    def _record(self, kind: str, record: Mapping[str, Any], *,
                details: dict[str, Any] | None, parameters: bool,
                writeback: WriteBack | None = None, maps: MapsWriteBack | None = None,
                session_path: str | None = None, operation: str | None = None) -> Recorded:
        record = check_record(record)
        operation = (writeback.operation if writeback else maps.operation if maps
                     else operation)
        key = event_key(kind, record["id"], operation)
        columns = record_columns(record)
        if session_path is not None:
            columns["session_path"] = session_path
        wall = writeback.wall if writeback else maps.wall if maps else None
        if wall is not None:
            columns["campaign_date"] = local_iso(wall) or columns["campaign_date"]
        with self._guard(f"record {key}"), self.db.transaction(write=True) as db:
            machine_id = _machine_id(db, machine_of(record))
            row = _json_values({
                "event_key": key, "machine_id": machine_id, "kind": kind,
                "recorded_at": utc_now(), "station": socket.gethostname(), "details": details,
                "record": clean_json(record),
                **{**columns, "software": columns["software"] or f"ogacq {__version__}"}})
            event_id = db.scalar(
                f"INSERT INTO {s.events.name} ({', '.join(row)}) "
                f"VALUES ({', '.join(':' + k for k in row)}) "
                "ON CONFLICT (event_key) DO NOTHING RETURNING id", row)
            if event_id is None:  # recorded before (here or by another station)
                write = writeback if writeback is not None else maps
                if write is not None:
                    _found_done(db, key, write)
                return Recorded(present=[key])
            if parameters:
                db.insert(s.parameters.name, [
                    {"event_id": event_id, "name": p.name, "value_mm": p.value_mm,
                     "u_mm": p.u_mm, "expanded_mm": p.expanded_mm, "k": p.k,
                     "std_mm": p.std_mm} for p in parameters_of(record)])
            if writeback is not None:
                db.insert(s.offset_states.name,
                          _state_rows(writeback, machine_of(record), event_id, machine_id))
            if maps is not None:
                db.insert(s.map_states.name, [_json_values(r) for r in _map_state_rows(
                    maps, machine_of(record), event_id, machine_id)])
        return Recorded(new=[key])

    # ------------------------------------------------------------------ reading
    def present(self, keys: list[str]) -> list[str]:
        """Those of the event ``keys`` (``entries.event_key``) already recorded."""
        marks = {f"key{i}": key for i, key in enumerate(keys)}
        with self._guard("read the events"), self.db.transaction(write=False) as db:
            found = set(db.scalars(
                f"SELECT event_key FROM {s.events.name} "
                f"WHERE event_key IN ({', '.join(':' + m for m in marks)})", marks)
                if keys else [])
        return [key for key in keys if key in found]

    def records_seen(self, record_id: str) -> int | None:
        """The most records the history saw in the session of ``record_id`` (its events'
        records count them): a session file holding fewer lost its tail. None when the
        history holds nothing of it."""
        with self._guard("read the events"), self.db.transaction(write=False) as db:
            records = db.scalars(f"SELECT record FROM {s.events.name} WHERE record_id = :id",
                                 {"id": record_id})
            counts = [typed_record(r).session_file.records for r in records
                      if isinstance(r, dict)]
        seen = [count for count in counts if count is not None]
        return max(seen) if seen else None

    def machines(self) -> list[Machine]:
        with self._guard("read the machines"), self.db.transaction(write=False) as db:
            rows = db.rows(f"SELECT id, name, serial FROM {s.machines.name} "
                           "ORDER BY name, serial")
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
        with self._guard("read the calibrations"), self.db.transaction(write=False) as db:
            rows = db.rows(f"SELECT * FROM {s.events.name} WHERE machine_id = :machine "
                           "AND kind = 'calibration'", {"machine": machine.id})
            params = db.rows(f"SELECT p.* FROM {s.parameters.name} p JOIN {s.events.name} e "
                             "ON e.id = p.event_id WHERE e.machine_id = :machine "
                             "AND e.kind = 'calibration'", {"machine": machine.id})
        by_event: dict[int, dict[str, Parameter]] = {}
        for p in params:
            by_event.setdefault(p.event_id, {})[p.name] = Parameter(
                p.name, p.value_mm, p.u_mm, p.expanded_mm, p.k, p.std_mm)
        out = []
        for r in rows:
            record = typed_record(r.record if isinstance(r.record, dict) else {})
            out.append(Calibration(
                r.record_id, r.campaign_date, r.operator, r.verdict, r.acceptance_decision,
                r.acceptance, r.ambient_c, _in_record_order(by_event.get(r.id, {}), r.record),
                r.session_path, r.session_sha256, r.instruments, r.environment, r.overrides,
                r.station, record.simulated, record.offsets_in_force_mm))
        return sorted(out, key=lambda c: (c.date or "", c.record_id))

    def events(self, machine: Machine) -> list[Event]:
        """Every event of the machine (calibrations, diagnoses, write-backs, restores),
        by date."""
        with self._guard("read the events"), self.db.transaction(write=False) as db:
            rows = db.rows("SELECT kind, record_id, campaign_date, operator, session_path, "
                           f"details FROM {s.events.name} WHERE machine_id = :machine",
                           {"machine": machine.id})
        return sorted((Event(r.kind, r.record_id, r.campaign_date, r.operator, r.session_path,
                             r.details) for r in rows),
                      key=lambda v: (v.date or "", s.EVENT_KINDS.index(v.kind), v.record_id))

    def records(self, machine: Machine, record_id: str) -> dict[str, Any] | None:
        """The record stored whole with the machine's calibration ``record_id``."""
        with self._guard("read a record"), self.db.transaction(write=False) as db:
            return db.scalar(f"SELECT record FROM {s.events.name} WHERE machine_id = :machine "
                             "AND record_id = :id AND kind = 'calibration'",
                             {"machine": machine.id, "id": record_id})

    def calibration_record(self, record_id: str) -> dict[str, Any] | None:
        """The record stored whole with the calibration ``record_id``, whichever machine's
        (a record's id names one session), None when the history has none."""
        with self._guard("read a record"), self.db.transaction(write=False) as db:
            return db.scalar(f"SELECT record FROM {s.events.name} WHERE record_id = :id "
                             "AND kind = 'calibration'", {"id": record_id})

    def results_history(self, machine: Machine) -> list[dict[str, Any]]:
        """The machine's calibrations as ``build_record(history=...)`` takes them
        (docs/calibration-record.md section 5): ``{"id", "date", "results"}`` each,
        the results as their records hold them, oldest first."""
        with self._guard("read the calibrations"), self.db.transaction(write=False) as db:
            rows = db.rows(f"SELECT record_id, campaign_date, record FROM {s.events.name} "
                           "WHERE machine_id = :machine AND kind = 'calibration'",
                           {"machine": machine.id})
        entries = [{"id": r.record_id, "date": r.campaign_date,
                    "results": typed_record(
                        r.record if isinstance(r.record, dict) else {}).results or {}}
                   for r in rows]
        return sorted(entries, key=lambda v: (v["date"] or "", v["id"]))

    def states(self, machine: Machine) -> list[OffsetState]:
        """The offsets states of the machine's write-backs and restores, oldest first."""
        with self._guard("read the offsets states"), self.db.transaction(write=False) as db:
            rows = db.rows(_states_of(s.offset_states), {"machine": machine.id})
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
        with self._guard("read the maps states"), self.db.transaction(write=False) as db:
            rows = db.rows(_states_of(s.map_states), {"machine": machine.id})
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


def _fields(write: WriteBack | MapsWriteBack, *names: str) -> dict[str, Any]:
    """A write's event details: what it did, then ``names`` of its fields, as JSON."""
    return clean_json({k: getattr(write, k) for k in ("operation", "action", "status", *names)})


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


def _states_of(table: s.Table) -> str:
    """The states of ``table`` of a machine (``:machine``), each with its event's record
    and session."""
    return (f"SELECT o.*, e.record_id, e.session_path FROM {table.name} o "
            f"JOIN {s.events.name} e ON e.id = o.event_id WHERE o.machine_id = :machine")


def _json_values(row: dict[str, Any]) -> dict[str, Any]:
    """``row`` with each JSON column's value marked as a document (None as JSON's null,
    as the history has always stored it)."""
    return {k: Json(v) if k in s.JSON_COLUMNS else v for k, v in row.items()}


def _found_done(db: Database, key: str, write: WriteBack | MapsWriteBack) -> None:
    """A write recorded as failed or interrupted (a Ctrl-C, a kill before its outcome)
    and recorded again as done, once read back in force by a resumed procedure: the
    history says what the machine holds, not the first word it was given."""
    if write.status != "done":
        return
    row = db.rows(f"SELECT id, details FROM {s.events.name} WHERE event_key = :key",
                  {"key": key})[0]
    details = dict(row.details or {})
    if details.get("status") == "done":
        return
    db.execute(f"UPDATE {s.events.name} SET details = :details WHERE id = :id",
               {"details": Json({**details, "status": "done"}), "id": row.id})
    states = s.offset_states if isinstance(write, WriteBack) else s.map_states
    db.execute(f"UPDATE {states.name} SET status = 'done' WHERE event_id = :id", {"id": row.id})


def _machine_id(db: Database, identity: tuple[str, str]) -> int:
    name, serial = identity
    m = s.machines.name
    db.execute(f"INSERT INTO {m} (name, serial, first_recorded) "
               "VALUES (:name, :serial, :first) ON CONFLICT (name, serial) DO NOTHING",
               {"name": name, "serial": serial, "first": utc_now()})
    found: int = db.scalar(f"SELECT id FROM {m} WHERE name = :name AND serial = :serial",
                           {"name": name, "serial": serial})
    return found


def _database(location: HistoryLocation, create: bool) -> Database:
    if location.path is None:
        assert location.url is not None
        return postgresql_database(location.url)
    path = location.path
    if not path.parent.is_dir():
        raise HistoryError(location, f"cannot open: there is no folder {path.parent}")
    if not create and not path.exists():
        raise HistoryError(location, "no history here (the file does not exist)")
    if path.exists() and not path.is_file():
        raise HistoryError(location, "is not a file")
    return sqlite_database(path)


def _prepare(db: Database, location: HistoryLocation, create: bool) -> int:
    """Check that the database is an ogacq history this version reads; create the
    schema in an empty one (when ``create``); migrate an older one (when ``create``:
    one opened to read is read as its schema stands). Returns the schema version."""
    tables = db.table_names()
    info_table = s.schema_info.name
    if info_table not in tables:
        if tables:
            listed = ", ".join(sorted(tables)[:5]) + (", ..." if len(tables) > 5 else "")
            raise HistoryError(location, f"is not an ogacq history: it holds other tables "
                               f"({listed}); give an empty database or an ogacq history")
        if not create:
            raise HistoryError(location, "holds no ogacq history yet (nothing was recorded)")
        for statement in s.ddl(db.backend):
            db.execute(statement)
        db.insert(info_table, [
            {"key": "application", "value": s.APPLICATION},
            {"key": "version", "value": str(s.SCHEMA_VERSION)},
            {"key": "created", "value": utc_now()},
            {"key": "created_by", "value": f"ogacq {__version__}"}])
        return s.SCHEMA_VERSION
    info: dict[str, str] = {row[0]: row[1] for row in db.rows(
        f'SELECT "key", value FROM {info_table}')}
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
            for statement in s.ddl(db.backend, s.MIGRATIONS[step]):
                db.execute(statement)
        db.execute(f"UPDATE {info_table} SET value = :version WHERE \"key\" = 'version'",
                   {"version": str(s.SCHEMA_VERSION)})
    return s.SCHEMA_VERSION
