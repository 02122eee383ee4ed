"""Writing error maps to the maps file ogacq applies, and undoing it: as the offsets
are written (``ogacq.writeback.execute``), shown, confirmed, audited, read back.

Order of work:
1. read the file again: if it changed since the plan was shown, stop (nothing
   written);
2. record the intent in the campaign's session, fsynced: the maps the file held
   (whole, so ``restore`` can put them back) and the checksum of the new ones;
3. replace the file atomically, read it back and compare its checksum with the
   plan's (a maps file is re-read from disk, not trusted from memory);
4. record the outcome: ``done`` with the checksum read back, or ``failed`` with the
   error and what the file holds.

Records are ``type = "maps"`` (``MapsRecord``), an operation's records sharing
its ``operation`` id (``maps-write-...``, ``maps-restore-...``).
"""

from __future__ import annotations

import contextlib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from ogacq_drivers.errors import DriverError
from ogacq.errors import OgacqError
from ogacq.io.errors import StorageError
from ogacq.logs import logger
from ogacq.model.axis_map import AxisMap
from ogacq.session.records import MapsRecord
from ogacq.session.store import LoadedSession
from ogacq.writeback.audit import AuditLog, intents_and_outcomes, new_operation_id
from ogacq.writeback.maps_table import (
    MAX_MAP_MM,
    MapsTable,
    Owner,
    maps_checksum,
    read_maps_table,
    write_maps_table,
)
from ogacq.writeback.outcome import Stage
from ogacq.writeback.policy import Refusal

log = logger(__name__)

Action = Literal["write", "restore"]


class MapsWriteError(DriverError):
    """The maps write stopped; the message says what the file holds now (exit 3)."""

    def __init__(self, message: str, *, written: bool, operation: str | None = None) -> None:
        self.written = written
        self.operation = operation
        super().__init__(message)


def _maps_json(maps: Mapping[str, AxisMap]) -> list[dict[str, Any]]:
    return [m.to_json() for m in maps.values()]


def _maps_of(entries: Any) -> dict[str, AxisMap]:
    return {m.axis: m for m in (AxisMap.from_json(e) for e in entries or ())}


@dataclass(frozen=True)
class MapsPlan:
    action: Action
    path: Path
    current: MapsTable
    new_maps: dict[str, AxisMap]
    refusals: tuple[Refusal, ...] = ()
    notes: tuple[str, ...] = ()
    restores_operation: str | None = None

    @property
    def new_checksum(self) -> str:
        return maps_checksum(self.new_maps)

    @property
    def nothing_to_do(self) -> bool:
        return self.current.checksum == self.new_checksum

    @property
    def refused(self) -> bool:
        return bool(self.refusals)

    def to_json(self) -> dict[str, Any]:
        return {"action": self.action, "file": str(self.path),
                "current_checksum": self.current.checksum, "new_checksum": self.new_checksum,
                "axes": {a: m.source for a, m in self.new_maps.items()},
                "refusals": [{"code": r.code, "message": r.message} for r in self.refusals],
                "notes": list(self.notes), "nothing_to_do": self.nothing_to_do}


@dataclass(frozen=True)
class MapsOperation:
    operation: str
    action: str
    status: Stage  # done, failed, interrupted
    path: Path
    old_maps: dict[str, AxisMap]
    old_checksum: str
    new_checksum: str  # as read back when done, else as intended
    new_maps: dict[str, AxisMap] = field(default_factory=dict)
    wall: float | None = None
    restores: str | None = None

    @property
    def old_state(self) -> str:
        return self.old_checksum

    @property
    def new_state(self) -> str:
        return self.new_checksum


def _operation(op: str, intent: MapsRecord, outcome: MapsRecord | None) -> MapsOperation:
    d = intent.details
    status = Stage(outcome.stage) if outcome else Stage.INTERRUPTED
    new = outcome.details.get("new_checksum") if outcome and status == Stage.DONE \
        else d.get("new_checksum")
    return MapsOperation(op, str(d.get("action", "write")), status,
                         Path(str(d.get("file", ""))), _maps_of(d.get("old_maps")),
                         str(d.get("old_checksum", "")), str(new),
                         _maps_of(d.get("new_maps")), intent.wall, d.get("restores"))


@dataclass(frozen=True)
class MapsFile:
    """The maps file as a write target (``ogacq.writeback.write_target``): its state is
    the checksum of the maps it holds, read from the disk each time."""

    path: Path
    #: the machine (name, serial) the maps are bound to; None: the one the file names
    owner: Owner | None = None
    noun = "maps"

    def held(self) -> str:
        return self.table().checksum

    def table(self) -> MapsTable:
        return read_maps_table(self.path, owner=self.owner)

    def same(self, a: str, b: str) -> bool:
        return a == b

    def describe(self, state: str) -> str:
        return f"maps {state[:12]}" + (" (no maps)" if state == maps_checksum({}) else "")

    def between(self, held: str, op: MapsOperation) -> bool:
        return False  # replaced whole (a rename): never half of one

    @staticmethod
    def operations(session: LoadedSession) -> list[MapsOperation]:
        """The maps writes and restores of the session's audit, oldest first."""
        return [_operation(*found)
                for found in intents_and_outcomes(session.of_type(MapsRecord))]

    def plan_write(self, new_maps: Mapping[str, AxisMap], *,
                   in_force_checksum: str | None) -> MapsPlan:
        """Replace the file's maps by ``new_maps`` (axes it does not name keep theirs).
        ``in_force_checksum``: the maps the campaign ran with; a file holding others
        changed since (a later write, a hand): refused as stale."""
        current = self.table()
        refusals = []
        largest = {a: max(abs(v) for v in (*m.forward_mm, *m.reverse_mm))
                   for a, m in new_maps.items() if m.positions_mm}
        beyond = {a: v for a, v in largest.items() if not v <= MAX_MAP_MM}
        if beyond:
            refusals.append(Refusal("too_large", "maps reaching " + ", ".join(
                f"{a} {v:g} mm" for a, v in beyond.items()) + f" exceed the {MAX_MAP_MM:g} "
                "mm limit of the offsets' gate: implausible for this machine; check the "
                "set-up"))
        if in_force_checksum is not None and current.checksum != in_force_checksum:
            refusals.append(Refusal("stale", f"the maps file {current.path} changed since the "
                                    f"campaign (then {in_force_checksum[:12]}, now "
                                    f"{current.checksum[:12]}): writing would replace a later "
                                    "change with this campaign's result"))
        merged = {**current.maps, **dict(new_maps)}
        kept = sorted(set(current.maps) - set(new_maps))
        notes = (f"the maps of {', '.join(kept)} stay as they are",) if kept else ()
        return MapsPlan("write", current.path, current, merged, tuple(refusals), notes)

    def plan_restore(self, op: MapsOperation, held: str) -> MapsPlan:
        """Put back the maps an earlier write (its intent record) replaced; refused when
        the file holds neither what that write wrote nor what it found."""
        current = self.table()
        refusals = []
        if current.checksum not in (op.new_checksum, op.old_checksum):
            refusals.append(Refusal("stale", f"the maps file no longer holds what "
                                    f"{op.operation} wrote (now {current.checksum[:12]}): "
                                    "restoring would undo a later change"))
        notes = () if op.status == Stage.DONE else (
            f"maps write {op.operation} did not finish ({op.status})",)
        return MapsPlan("restore", current.path, current, dict(op.old_maps),
                        tuple(refusals), notes, op.operation)

    def execute(self, plan: MapsPlan, audit: AuditLog, confirmed_by: str) -> str:
        """Write ``plan`` (approved) and verify it by reading the file back."""
        now = self.table()
        if now.checksum != plan.current.checksum:
            raise MapsWriteError(f"the maps file {plan.path} changed since the plan was made: "
                                 "nothing written; show the plan again", written=False)
        operation = new_operation_id(f"maps-{plan.action}")
        try:
            audit.record_maps(Stage.INTENT, operation=operation, action=plan.action,
                              file=str(plan.path), old_maps=_maps_json(now.maps),
                              old_checksum=now.checksum, new_maps=_maps_json(plan.new_maps),
                              new_checksum=plan.new_checksum,
                              restores=plan.restores_operation, forced=[],
                              refusals=[r.message for r in plan.refusals],
                              confirmed_by=confirmed_by)
        except StorageError as exc:  # no write without the record of what to restore
            raise MapsWriteError(f"{exc}: the intent record could not be written, so the "
                                 "maps file was not touched", written=False) from None
        back = self._write_and_read_back(plan, audit, operation)
        try:
            audit.record_maps(Stage.DONE, operation=operation, action=plan.action,
                              file=str(plan.path), new_checksum=back.checksum,
                              axes={a: m.checksum() for a, m in back.maps.items()})
        except StorageError as exc:
            raise MapsWriteError(f"maps {plan.action} {operation}: the file holds "
                                 f"{back.checksum[:12]} (read back), but the session could not "
                                 f"record it: {exc}", written=True, operation=operation) from None
        log.info("maps %s done: %s", operation, back.checksum[:12])
        return operation

    def _owner(self, current: MapsTable) -> Owner:
        """The machine to bind the maps written to: this target's, else the one the
        file named (a restore by hand keeps it)."""
        return self.owner or current.owner or ("", "")

    def record_found(self, op: MapsOperation, held: str, audit: AuditLog) -> None:
        table = self.table()
        audit.record_maps(Stage.DONE, operation=op.operation, action=op.action,
                          file=str(self.path), new_checksum=held,
                          axes={a: m.checksum() for a, m in table.maps.items()},
                          found="read back after the write was cut short")

    def _write_and_read_back(self, plan: MapsPlan, audit: AuditLog, operation: str,
                             ) -> MapsTable:
        try:
            back = write_maps_table(plan.path, plan.new_maps,
                                    session=str(audit.session.path.resolve()),
                                    action=plan.action, owner=self._owner(plan.current))
            if back.checksum != plan.new_checksum:
                raise OSError(f"read back checksum {back.checksum[:12]}, wrote "
                              f"{plan.new_checksum[:12]}")
            return back
        except (OSError, OgacqError) as exc:
            held: str | None = None
            with contextlib.suppress(OgacqError, OSError):
                held = read_maps_table(plan.path).checksum
            with contextlib.suppress(StorageError):
                audit.record_maps(Stage.FAILED, operation=operation, action=plan.action,
                                  error=str(exc), held_checksum=held)
            raise MapsWriteError(f"maps {plan.action} {operation} failed: {exc}. The file "
                                 f"holds {held[:12] if held else 'unknown'}; the old maps are "
                                 "in the session", written=True, operation=operation) from None
