"""Audit records of write-backs, appended to the campaign's own session.

Every attempt leaves a ``type = "offsets"`` record: ``refused`` and
``declined`` when nothing was written; otherwise ``intent`` (fsynced *before*
the first write, with the old values, so a crash mid-write still leaves what
to restore), then ``done`` (values as read back) or ``failed`` (the error and
what the controller held afterwards). Records of one attempt share an
``operation`` id; ``restore`` reads them back.
"""

from __future__ import annotations

import secrets
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any, TypeVar

from ogacq.errors import StorageError
from ogacq.io.dates import local_time_text
from ogacq.session.records import MapsRecord, OffsetsRecord
from ogacq.session.store import LoadedSession, SessionWriter
from ogacq.writeback.outcome import ENDS, Stage


class AuditLog:
    """Appends audit records to a session. Used as a context manager it holds the
    session from the start (one writer at a time), before any controller is touched."""

    def __init__(self, session: LoadedSession) -> None:
        self.session = session
        self._writer: SessionWriter | None = None

    def record(self, stage: Stage, **fields: Any) -> None:
        self._append(OffsetsRecord(stage=stage, details=fields))

    def record_maps(self, stage: Stage, **fields: Any) -> None:
        """A stage of a maps write (``ogacq.writeback.maps``)."""
        self._append(MapsRecord(stage=stage, details=fields))

    def _append(self, record: OffsetsRecord | MapsRecord) -> None:
        self._open()
        assert self._writer is not None
        self._writer.write(record)
        if record.stage == Stage.INTENT:  # what to restore on the disk before the target changes
            self._writer.sync()

    def close(self) -> None:
        if self._writer is not None:
            self._writer.close()

    def __enter__(self) -> AuditLog:
        self._open()
        return self

    def _open(self) -> None:
        if self._writer is None:
            # the session as the evidence was read from it: a campaign that wrote to it
            # since (or still holds it) makes this write-back wait for a fresh look
            try:
                self._writer = SessionWriter.append_to(self.session.path,
                                                       self.session.size_bytes or None)
            except StorageError as exc:  # opened before any controller: nothing was changed
                raise StorageError(self.session.path, exc.cause,
                                   "append the audit record, so nothing was written to the "
                                   "controller") from None

    def __exit__(self, *exc: object) -> None:
        self.close()


def new_operation_id(action: str) -> str:
    return f"{action}-{secrets.token_hex(4)}"


@dataclass(frozen=True)
class Operation:
    """One write-back or restore as its records tell it."""

    operation: str
    action: str
    status: Stage  # done, failed, interrupted (an intent with no outcome: the process died)
    old_mm: dict[str, float]
    new_mm: dict[str, float]  # as read back when done, else as intended
    profile: str | None
    nvm_saved: bool
    wall: float | None
    #: the values written outlive a power cycle (a table, or saved to NVM); None: not
    #: recorded (a write-back before issue 25, or one that did not finish)
    survives_power_cycle: bool | None = None
    restores: str | None = None  # a restore: the write (or history state) it undoes
    held_mm: dict[str, float] | None = None  # failed: what the controller held after it

    @property
    def old_state(self) -> dict[str, float]:
        return self.old_mm

    @property
    def new_state(self) -> dict[str, float]:
        return self.new_mm

    def as_mapping(self) -> dict[str, Any]:
        return {"operation": self.operation, "action": self.action, "status": self.status,
                "old_mm": self.old_mm, "new_mm": self.new_mm, "profile": self.profile,
                "nvm_saved": self.nvm_saved, "wall": self.wall,
                "survives_power_cycle": self.survives_power_cycle}


StagedRecord = TypeVar("StagedRecord", OffsetsRecord, MapsRecord)


def intents_and_outcomes(records: Iterable[StagedRecord],
                         ) -> list[tuple[str, StagedRecord, StagedRecord | None]]:
    """Each operation of an audit trail, oldest first: its id, its intent, and the
    record of how it ended (done or failed; None: interrupted)."""
    intents: dict[str, StagedRecord] = {}
    outcomes: dict[str, StagedRecord] = {}
    for record in records:
        op = record.details.get("operation")
        if not op:
            continue
        if record.stage == Stage.INTENT:
            intents[op] = record
        elif record.stage in ENDS:
            outcomes[op] = record
    return [(op, intent, outcomes.get(op)) for op, intent in intents.items()]


def operations(session: LoadedSession) -> list[Operation]:
    """Write-backs and restores recorded in the session, oldest first."""
    out = []
    for op, intent, outcome in intents_and_outcomes(session.of_type(OffsetsRecord)):
        status = Stage(outcome.stage) if outcome else Stage.INTERRUPTED
        new = outcome.details["new_mm"] if outcome and status == Stage.DONE \
            else intent.details["new_mm"]
        out.append(Operation(op, intent.details.get("action", "write"), status,
                             dict(intent.details["old_mm"]), dict(new),
                             intent.details.get("profile"),
                             bool(outcome and outcome.details.get("nvm_saved", False)),
                             intent.wall,
                             outcome.details.get("survives_power_cycle") if outcome else None,
                             intent.details.get("restores"),
                             _held_after(outcome) if status == Stage.FAILED else None))
    return out


def _held_after(outcome: OffsetsRecord | None) -> dict[str, float] | None:
    held = outcome.details.get("held_mm") if outcome else None
    return dict(held) if isinstance(held, dict) else None


def last_write(session: LoadedSession) -> Operation | None:
    writes = [op for op in operations(session) if op.action == "write"]
    return writes[-1] if writes else None


@dataclass(frozen=True)
class OffsetsWrite:
    """A write-back (or restore) of joint offsets as the record states it: its
    ``writeback`` entries (docs/calibration-record.md section 5)."""

    when: str
    action: str  # "write" or "restore"
    status: Stage  # done, failed, interrupted
    old_mm: dict[str, float]
    new_mm: dict[str, float]  # as read back when done, else as intended
    details: str  # controller profile, saved to non-volatile memory, operation id


def offsets_writes(session: LoadedSession) -> tuple[OffsetsWrite, ...]:
    """The write-backs recorded in the session, in words: where the values were kept
    and whether they outlive a power cycle."""
    out = []
    for op in operations(session):
        saved = ("saved to non-volatile memory" if op.nvm_saved
                 else "not saved to non-volatile memory")
        if op.survives_power_cycle is True and not op.nvm_saved:
            saved = "in the software offset table: survives a power cycle"
        elif op.survives_power_cycle is True:
            saved = "saved to non-volatile memory: survives a power cycle"
        elif op.survives_power_cycle is False:
            saved = ("not saved to non-volatile memory: a power cycle brings back the "
                     "offsets the drive saved before")
        details = ", ".join(d for d in (f"controller {op.profile}" if op.profile else "",
                                        saved, f"operation {op.operation}") if d)
        out.append(OffsetsWrite(local_time_text(op.wall), op.action, op.status,
                                dict(op.old_mm), dict(op.new_mm), details))
    return tuple(out)
