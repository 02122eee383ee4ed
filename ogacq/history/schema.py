"""The history's tables: one declaration for SQLite and PostgreSQL, rendered as each
backend's DDL (the types, keys and indexes SQLAlchemy Core rendered for the histories
earlier versions created, so that those and new ones are the same tables).

- ``ogacq_schema``: key/value rows; ``application`` says the database is an
  ogacq history, ``version`` which schema it holds, so that a later ogacq can
  migrate it (``MIGRATIONS``) and an older one refuses a newer schema;
- ``ogacq_machines``: one row per machine (name and serial);
- ``ogacq_events``: every calibration, diagnosis, write-back and restore, with
  what a metrologist asks of it (date, operator, verdict, acceptance,
  instruments, environment, overrides), the session's path and SHA-256, and the
  record (``ogacq-record/1``) whole; ``event_key`` is unique, so recording the
  same thing twice (two stations, a retry) leaves one row;
- ``ogacq_parameters``: each identified parameter of an event with its u, U, k;
- ``ogacq_offset_states``: the offsets a write-back or restore found on the
  controller (``before``) and left there (``after``), which ``ogacq offsets
  restore --to STATE`` can put back;
- ``ogacq_map_states`` (schema 2): the error maps a maps write or restore found in
  the maps file ogacq applies and left there, each map whole (``ogacq-axis-map/1``)
  with the file's checksum.

A ``calibrate`` event is one ``ogacq calibrate`` procedure: its details name the
write-backs it made and say whether the validation kept them or they were restored,
and why.
"""

from __future__ import annotations

from dataclasses import dataclass

APPLICATION = "ogacq-history"
SCHEMA_VERSION = 2

EVENT_KINDS = ("calibration", "diagnosis", "write-back", "restore", "map-write", "map-restore",
               "calibrate")

# A column's type, as both backends declare it. JSON is a document stored whole
# (PostgreSQL's json type; SQLite keeps its text under that name, as SQLAlchemy did).
INTEGER, FLOAT, TEXT, JSON = "INTEGER", "FLOAT", "TEXT", "JSON"


def string(length: int) -> str:
    return f"VARCHAR({length})"


def quoted(name: str) -> str:
    """A column's name as SQL takes it: ``key`` is a keyword of SQLite's."""
    return f'"{name}"' if name == "key" else name


@dataclass(frozen=True)
class Column:
    name: str
    type: str
    nullable: bool = True
    primary_key: bool = False
    serial: bool = False  # numbered by the database (PostgreSQL's SERIAL, SQLite's rowid)
    references: str | None = None  # "table (column)"
    index: bool = False
    unique: bool = False


@dataclass(frozen=True)
class Table:
    name: str
    columns: tuple[Column, ...]
    unique: tuple[tuple[str, tuple[str, ...]], ...] = ()  # (constraint's name, columns)

    @property
    def json_columns(self) -> tuple[str, ...]:
        return tuple(c.name for c in self.columns if c.type == JSON)

    def ddl(self, backend: str) -> list[str]:
        """CREATE TABLE and its indexes, in ``backend``'s words: the statements SQLAlchemy
        Core 2.0 rendered for this schema on both dialects (compared one by one when it
        was replaced; ``tests/history/earlier_history.sql`` is a history it made)."""
        lines = []
        for c in self.columns:
            kind = "SERIAL" if c.serial and backend == "postgresql" else c.type
            lines.append(f"{quoted(c.name)} {kind}" + (" NOT NULL" if c.primary_key
                                                       or not c.nullable else ""))
        keys = [quoted(c.name) for c in self.columns if c.primary_key]
        lines.append(f"PRIMARY KEY ({', '.join(keys)})")
        lines += [f"UNIQUE ({c.name})" for c in self.columns if c.unique]
        lines += [f"CONSTRAINT {name} UNIQUE ({', '.join(columns)})"
                  for name, columns in self.unique]
        lines += [f"FOREIGN KEY({c.name}) REFERENCES {c.references}" for c in self.columns
                  if c.references]
        body = ",\n\t".join(lines)
        return [f"CREATE TABLE {self.name} (\n\t{body}\n)",
                *(f"CREATE INDEX ix_{self.name}_{c.name} ON {self.name} ({c.name})"
                  for c in self.columns if c.index)]


def _key(name: str, references: str) -> Column:
    return Column(name, INTEGER, nullable=False, references=references, index=True)


MACHINE_ID = "ogacq_machines (id)"
EVENT_ID = "ogacq_events (id)"

schema_info = Table("ogacq_schema", (
    Column("key", string(64), primary_key=True),
    Column("value", string(200), nullable=False),
))

machines = Table("ogacq_machines", (
    Column("id", INTEGER, primary_key=True, serial=True),
    Column("name", string(200), nullable=False),
    Column("serial", string(200), nullable=False),  # "" when the machine file gives none
    Column("first_recorded", string(40), nullable=False),
), unique=(("ogacq_machines_identity", ("name", "serial")),))

events = Table("ogacq_events", (
    Column("id", INTEGER, primary_key=True, serial=True),
    Column("event_key", string(240), nullable=False, unique=True),
    _key("machine_id", MACHINE_ID),
    Column("kind", string(20), nullable=False),
    Column("record_id", string(64), nullable=False, index=True),
    Column("campaign_date", string(40)),  # the calibration's date; a write-back's own time
    Column("recorded_at", string(40), nullable=False),  # UTC, when the row was written
    Column("station", string(200)),  # the computer that recorded it
    Column("software", string(80)),
    Column("operator", string(200)),
    Column("session_path", TEXT),
    Column("session_sha256", string(64)),
    Column("verdict", JSON),
    Column("acceptance_decision", string(20)),  # as found
    Column("acceptance", JSON),
    Column("instruments", JSON),
    Column("environment", JSON),
    Column("ambient_c", FLOAT),  # at the start, for the tables
    Column("overrides", JSON),
    Column("details", JSON),  # a diagnosis's findings, a write-back's operation
    Column("record", JSON),  # the ogacq-record/1 document, whole
))

parameters = Table("ogacq_parameters", (
    Column("event_id", INTEGER, primary_key=True, references=EVENT_ID),
    Column("name", string(80), primary_key=True),  # "joint_offset.x"
    Column("value_mm", FLOAT, nullable=False),
    Column("u_mm", FLOAT),  # standard uncertainty u_c, from the budget
    Column("expanded_mm", FLOAT),  # U
    Column("k", FLOAT),
    Column("std_mm", FLOAT),  # the fit's std (stands in when there is no budget)
))

# What an offsets state and a maps state both hold, in this order.
_STATE = (
    Column("state_id", string(32), primary_key=True),
    _key("event_id", EVENT_ID),
    _key("machine_id", MACHINE_ID),
    Column("stage", string(10), nullable=False),  # before, after
    Column("at", string(40)),  # local ISO time of the operation
    Column("wall", FLOAT),  # the same as a Unix time, for ordering
    Column("operation", string(80), nullable=False),
    Column("action", string(20), nullable=False),  # write, restore
    Column("status", string(20), nullable=False),  # done, failed, interrupted
)

offset_states = Table("ogacq_offset_states", (
    *_STATE,
    Column("profile", string(80)),
    Column("x_mm", FLOAT), Column("y_mm", FLOAT), Column("z_mm", FLOAT),
))

map_states = Table("ogacq_map_states", (
    *_STATE,
    Column("maps_file", TEXT),
    Column("checksum", string(64)),  # ogacq.writeback.maps_table.maps_checksum
    Column("maps", JSON),  # [ogacq-axis-map/1, ...]
))

# In the order they are created (a table after those its keys refer to).
TABLES = (schema_info, machines, events, parameters, offset_states, map_states)
JSON_COLUMNS = frozenset(name for table in TABLES for name in table.json_columns)


def ddl(backend: str, tables: tuple[Table, ...] = TABLES) -> list[str]:
    """The statements that create ``tables`` in ``backend`` ("sqlite", "postgresql")."""
    return [statement for table in tables for statement in table.ddl(backend)]


# version -> the tables that bring a database of that version to the next one.
MIGRATIONS: dict[int, tuple[Table, ...]] = {
    1: (map_states,),  # schema 2: the maps states
}
