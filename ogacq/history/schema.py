"""The history's tables: one schema for SQLite and PostgreSQL (SQLAlchemy Core).

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

from collections.abc import Callable
from typing import Any

from sqlalchemy import (
    JSON,
    Column,
    Connection,
    Float,
    ForeignKey,
    Integer,
    MetaData,
    String,
    Table,
    Text,
    UniqueConstraint,
)

APPLICATION = "ogacq-history"
SCHEMA_VERSION = 2

EVENT_KINDS = ("calibration", "diagnosis", "write-back", "restore", "map-write", "map-restore",
               "calibrate")

metadata = MetaData()

schema_info = Table(
    "ogacq_schema", metadata,
    Column("key", String(64), primary_key=True),
    Column("value", String(200), nullable=False),
)

machines = Table(
    "ogacq_machines", metadata,
    Column("id", Integer, primary_key=True, autoincrement=True),
    Column("name", String(200), nullable=False),
    Column("serial", String(200), nullable=False),  # "" when the machine file gives none
    Column("first_recorded", String(40), nullable=False),
    UniqueConstraint("name", "serial", name="ogacq_machines_identity"),
)

events = Table(
    "ogacq_events", metadata,
    Column("id", Integer, primary_key=True, autoincrement=True),
    Column("event_key", String(240), nullable=False, unique=True),
    Column("machine_id", ForeignKey(machines.c.id), nullable=False, index=True),
    Column("kind", String(20), nullable=False),
    Column("record_id", String(64), nullable=False, index=True),
    Column("campaign_date", String(40)),  # the calibration's date; a write-back's own time
    Column("recorded_at", String(40), nullable=False),  # UTC, when the row was written
    Column("station", String(200)),  # the computer that recorded it
    Column("software", String(80)),
    Column("operator", String(200)),
    Column("session_path", Text),
    Column("session_sha256", String(64)),
    Column("verdict", JSON),
    Column("acceptance_decision", String(20)),  # as found
    Column("acceptance", JSON),
    Column("instruments", JSON),
    Column("environment", JSON),
    Column("ambient_c", Float),  # at the start, for the tables
    Column("overrides", JSON),
    Column("details", JSON),  # a diagnosis's findings, a write-back's operation
    Column("record", JSON),  # the ogacq-record/1 document, whole
)

parameters = Table(
    "ogacq_parameters", metadata,
    Column("event_id", ForeignKey(events.c.id), primary_key=True),
    Column("name", String(80), primary_key=True),  # "joint_offset.x"
    Column("value_mm", Float, nullable=False),
    Column("u_mm", Float),  # standard uncertainty u_c, from the budget
    Column("expanded_mm", Float),  # U
    Column("k", Float),
    Column("std_mm", Float),  # the fit's std (stands in when there is no budget)
)

def _state_columns() -> list[Column[Any]]:
    """What an offsets state and a maps state both hold, in this order (new columns for
    each table: a Column belongs to one)."""
    return [
        Column("state_id", String(32), primary_key=True),
        Column("event_id", ForeignKey(events.c.id), nullable=False, index=True),
        Column("machine_id", ForeignKey(machines.c.id), nullable=False, index=True),
        Column("stage", String(10), nullable=False),  # before, after
        Column("at", String(40)),  # local ISO time of the operation
        Column("wall", Float),  # the same as a Unix time, for ordering
        Column("operation", String(80), nullable=False),
        Column("action", String(20), nullable=False),  # write, restore
        Column("status", String(20), nullable=False),  # done, failed, interrupted
    ]


offset_states = Table(
    "ogacq_offset_states", metadata, *_state_columns(),
    Column("profile", String(80)),
    Column("x_mm", Float), Column("y_mm", Float), Column("z_mm", Float),
)

map_states = Table(
    "ogacq_map_states", metadata, *_state_columns(),
    Column("maps_file", Text),
    Column("checksum", String(64)),  # ogacq.writeback.maps_table.maps_checksum
    Column("maps", JSON),  # [ogacq-axis-map/1, ...]
)


def _create(table: Table) -> Callable[[Connection], None]:
    """A migration step: create ``table`` as this schema declares it (each backend's
    own DDL, indexes included)."""
    return lambda conn: table.create(conn)


# version -> the steps (SQL, or a function of the connection) that bring a database of
# that version to the next one.
MIGRATIONS: dict[int, tuple[str | Callable[[Connection], None], ...]] = {
    1: (_create(map_states),),  # schema 2: the maps states
}
