"""One protocol for what ogacq writes to a machine: the controller's joint offsets
(``ogacq.writeback.offsets_target``) and the maps file (``ogacq.writeback.maps``).

A target reads what it holds, lists its operations from the session's audit, plans
the restore of one, and carries a plan out (intent recorded, written, read back,
outcome recorded). What is done with any target is written once, here:

- which write of the audit left what the target holds (``write_in_force``): a write
  whose new values may be on the machine counts as written until read back otherwise,
  whatever its audit says of its end (done, failed, or interrupted: killed between
  the write and its ``done`` record);
- whether what is held is a write's own half-done state (``left_half_way``): some
  axes written, some not, by an interrupted write, not by someone else;
- putting back what a write replaced (``restore``), said restored only once the
  target, read back, holds the previous state again.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol, TypeVar

from ogacq.errors import DriverError, Refused
from ogacq.session.store import LoadedSession
from ogacq.writeback.audit import AuditLog
from ogacq.writeback.outcome import Stage
from ogacq.writeback.policy import Refusal

State = TypeVar("State")
State_co = TypeVar("State_co", covariant=True)


class TargetOperation(Protocol[State_co]):
    """One write or restore of a target, as its audit records tell it."""

    @property
    def operation(self) -> str: ...
    @property
    def action(self) -> str: ...  # write, restore
    @property
    def status(self) -> str: ...  # done, failed, interrupted
    @property
    def old_state(self) -> State_co: ...  # what it replaced
    @property
    def new_state(self) -> State_co: ...  # what it wrote: read back when done, else intended
    @property
    def restores(self) -> str | None: ...  # a restore: the operation it undoes


class TargetPlan(Protocol):
    @property
    def refusals(self) -> tuple[Refusal, ...]: ...
    @property
    def refused(self) -> bool: ...
    @property
    def nothing_to_do(self) -> bool: ...


Plan = TypeVar("Plan", bound=TargetPlan)
Op = TypeVar("Op", bound=TargetOperation[Any])


class WriteTarget(Protocol[State, Op, Plan]):
    """The controller's offsets or the maps file, seen the same way."""

    noun: str  # "offsets", "maps": the audit's kind and the messages'

    def held(self) -> State:
        """What the target holds now, read from it (never from memory)."""

    def same(self, a: State, b: State) -> bool:
        """Whether two states are the same as the target stores them."""

    def describe(self, state: State) -> str:
        """A state in words, for the messages."""

    def between(self, held: State, op: Op) -> bool:
        """Whether ``held`` is part old, part new state of ``op`` (a write cut half-way)."""

    def operations(self, session: LoadedSession) -> Sequence[Op]:
        """The target's writes and restores in the session's audit, oldest first."""

    def plan_restore(self, op: Op, held: State) -> Plan:
        """Put back what ``op`` replaced, from ``held``; refused when held is neither
        what ``op`` left nor what it found."""

    def execute(self, plan: Plan, audit: AuditLog, confirmed_by: str) -> str:
        """Carry ``plan`` out with read-back and audit records: its operation id."""

    def record_found(self, op: Op, held: State, audit: AuditLog) -> None:
        """The ``done`` record of an operation cut short whose new state was read back
        from the target afterwards: the audit, and the history after it, then say what
        is in force."""


class NotRestored(DriverError):
    """A restore whose read-back is not the previous state: what is held is said."""


AnyTarget = WriteTarget[Any, Any, Any]


def present(*targets: AnyTarget | None) -> list[AnyTarget]:
    """The targets there are (a controller may name no maps file)."""
    return [t for t in targets if t is not None]


def write_in_force(target: WriteTarget[State, Op, Plan], ops: Sequence[Op],
                   held: State) -> Op | None:
    """The latest write whose new state is what the target holds, done or not: a write
    killed after the target changed and before its ``done`` record left its values in
    force all the same. None: no write of the audit left what is held."""
    for op in reversed(ops):
        if op.action == "write" and target.same(held, op.new_state):
            return op
    return None


def left_half_way(target: WriteTarget[State, Op, Plan], ops: Sequence[Op],
                  held: State) -> Op | None:
    """The write of the audit that did not finish and left ``held`` part old, part new
    (x and y written, z not yet): its own state, not a later change."""
    for op in reversed(ops):
        if op.action == "write" and op.status != Stage.DONE and target.between(held, op):
            return op
    return None


def restore(target: WriteTarget[State, Op, Plan], op: Op, session: LoadedSession,
            audit: AuditLog, confirmed_by: str, *, forced: bool = False) -> str | None:
    """Put back what ``op`` replaced and check it by reading the target back: the
    restore's operation id (an earlier one of the audit when the target already held
    the previous state: restored before a kill), None when nothing of ``op`` was ever
    in force. Raises Refused when the target holds something else (a later change),
    NotRestored when the read-back is not the previous state. ``forced``: the operator
    saw the refusals and restores past them."""
    held = target.held()
    plan = target.plan_restore(op, held)
    if plan.refused and not forced:
        raise Refused(f"cannot restore the {target.noun}: "
                      + "; ".join(r.message for r in plan.refusals))
    operation: str | None
    earlier = None
    if plan.nothing_to_do:
        earlier = _restore_of(target.operations(session), op)
        operation = earlier.operation if earlier is not None else None
    else:
        operation = target.execute(plan, audit, confirmed_by)
    back = target.held()
    if not target.same(back, op.old_state):
        raise NotRestored(f"the {target.noun} were not restored: read back "
                          f"{target.describe(back)}, not the previous "
                          f"{target.describe(op.old_state)}")
    if earlier is not None and earlier.status != Stage.DONE:
        target.record_found(earlier, back, audit)
    return operation


def found_in_force(target: WriteTarget[State, Op, Plan], session: LoadedSession,
                   audit: AuditLog) -> Op | None:
    """The write that left what the target holds (``write_in_force``), its ``done``
    recorded now when it was cut short before: read back, it is in force."""
    held = target.held()
    op = write_in_force(target, target.operations(session), held)
    if op is not None and op.status != Stage.DONE:
        target.record_found(op, held, audit)
    return op


def _restore_of(ops: Sequence[Op], op: Op) -> Op | None:
    """The restore of ``op`` in the audit (done or cut short: the read-back decides)."""
    for other in reversed(ops):
        if other.action == "restore" and other.restores == op.operation:
            return other
    return None
