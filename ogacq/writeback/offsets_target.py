"""The controller's joint offsets as a write target (``ogacq.writeback.write_target``):
the drive registers, or the software offset table of a profile without one."""

from __future__ import annotations

import contextlib
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

from ogacq_drivers.axes.controller import AxisController
from ogacq.errors import DriverError, StorageError
from ogacq.model.parameters import AXES
from ogacq.model.units import signed_per_axis
from ogacq.session.store import LoadedSession
from ogacq.writeback.audit import AuditLog, Operation, operations
from ogacq.writeback.execute import WriteOptions, WriteOutcome, execute_plan, preflight
from ogacq.writeback.outcome import Stage
from ogacq.writeback.policy import ControllerFacts, OffsetPlan, plan_restore
from ogacq.writeback.table import read_offset_table

Offsets = dict[str, float]


@dataclass
class ControllerOffsets:
    """The offsets of an open controller (or of its software table, ``offsets_file``)."""

    controller: AxisController
    offsets_file: Path | None = None
    options: WriteOptions = field(default_factory=WriteOptions)
    noun = "offsets"
    #: the outcome of the last ``execute`` (what the CLI prints of it)
    outcome: WriteOutcome | None = None

    @property
    def facts(self) -> ControllerFacts:
        return ControllerFacts.of(self.controller.profile)

    def held(self) -> Offsets:
        if self.facts.kind == "software" and self.offsets_file is not None:
            return read_offset_table(self.offsets_file).offsets_mm  # the file, not memory
        return self.controller.read_offsets()

    def same(self, a: Offsets, b: Offsets) -> bool:
        return all(self.facts.same(a[x], b[x]) for x in AXES)

    def describe(self, state: Offsets) -> str:
        return f"{signed_per_axis(state)} mm"

    def between(self, held: Offsets, op: Operation) -> bool:
        facts = self.facts
        return all(facts.same(held[a], op.old_mm[a]) or facts.same(held[a], op.new_mm[a])
                   for a in AXES)

    def operations(self, session: LoadedSession) -> Sequence[Operation]:
        return operations(session)

    def plan_restore(self, op: Operation, held: Offsets) -> OffsetPlan:
        return plan_restore(op, held, self.facts)

    def execute(self, plan: OffsetPlan, audit: AuditLog, confirmed_by: str) -> str:
        options = replace(self.options, confirmed_by=confirmed_by)
        try:
            preflight(self.controller, plan, options)
        except DriverError as exc:
            with contextlib.suppress(StorageError):
                audit.record(Stage.REFUSED, action=plan.action, current_mm=plan.current_mm,
                             new_mm=plan.new_mm, reasons=[f"pre-flight: {exc}"],
                             codes=["preflight"])
            raise DriverError(f"pre-flight check, nothing written: {exc}") from None
        self.outcome = execute_plan(self.controller, plan, audit, options,
                                    offsets_file=self.offsets_file)
        return self.outcome.operation

    def record_found(self, op: Operation, held: Offsets, audit: AuditLog) -> None:
        facts = self.facts
        audit.record(Stage.DONE, operation=op.operation, action=op.action, old_mm=op.old_mm,
                     new_mm=held, takes_effect=facts.takes_effect, rehomed=False,
                     home_positions_mm=None, nvm_saved=False,
                     offsets_file=str(self.offsets_file) if self.offsets_file else None,
                     survives_power_cycle=self.offsets_file is not None,
                     found="read back after the write was cut short")
