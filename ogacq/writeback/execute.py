"""Carrying out an offset plan on the controller, with read-back and audit records.

Order of work, each step checked before the next:
1. read the offsets again: if they moved since the plan was shown, stop (nothing written);
2. record the intent (old and new values) in the session, fsynced;
3. disable the drive first where the profile says offsets are written disabled;
4. write, then read back and compare within the storage step (register counts, or
   the software table re-read from disk after its atomic replacement);
5. save to non-volatile memory, only when asked;
6. re-home where the offset takes effect at homing, and check that each axis then
   reads ``-o`` at its home point (``q = raw - o`` with raw = 0 there);
7. record the outcome: ``done`` with the values read back, or ``failed`` with the
   error and what the controller holds, so ``restore`` always has what it needs.
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass
from pathlib import Path

from ogacq_drivers.axes.controller import AxisController
from ogacq_drivers.axes.preflight import check_home, check_identity
from ogacq_drivers.errors import DriverError
from ogacq.io.errors import InputError, StorageError
from ogacq.logs import logger
from ogacq.model.parameters import AXES
from ogacq.model.units import signed_per_axis as _fmt
from ogacq.writeback.audit import AuditLog, new_operation_id
from ogacq.writeback.outcome import Stage
from ogacq.writeback.policy import OffsetPlan
from ogacq.writeback.table import read_offset_table, write_offset_table

log = logger(__name__)


class WriteBackError(DriverError):
    """The write-back stopped; the message says what the controller holds now."""

    def __init__(self, message: str, *, written: bool, operation: str | None = None,
                 disk: bool = False) -> None:
        self.written = written  # False: nothing was sent to the controller or the table
        self.operation = operation
        if disk:  # the session's disk stopped it, not the controller (still exit 3)
            self.label = "error"
        super().__init__(message)


@dataclass(frozen=True)
class WriteOptions:
    save_nvm: bool = False
    rehome: bool = True
    forced: tuple[str, ...] = ()  # refusal codes the operator forced past
    confirmed_by: str = "prompt"  # or "--yes"
    port: str | None = None  # recorded with the audit


@dataclass(frozen=True)
class WriteOutcome:
    operation: str
    action: str
    old_mm: dict[str, float]
    new_mm: dict[str, float]  # as read back
    takes_effect: str
    rehomed: bool
    home_positions_mm: dict[str, float] | None
    nvm_saved: bool
    offsets_file: Path | None

    @property
    def survives_power_cycle(self) -> bool:
        """Whether the values written are still there after the drive is switched off
        and on: a software table is a file; a drive register only once saved to its
        non-volatile memory (else the drive loads the values it saved before)."""
        return self.offsets_file is not None or self.nvm_saved

    @property
    def pending_homing(self) -> bool:
        return self.takes_effect == "at_next_homing" and not self.rehomed


def _held(controller: AxisController, plan: OffsetPlan,
          offsets_file: Path | None) -> dict[str, float] | None:
    """What the controller (or the table on disk) holds now, if it can still be read."""
    try:
        if plan.facts.kind == "software" and offsets_file is not None:
            return read_offset_table(offsets_file).offsets_mm
        return controller.read_offsets()
    except (DriverError, InputError, OSError) as exc:
        log.error("offsets could not be read back after the failure: %s", exc)
        return None


def preflight(controller: AxisController, plan: OffsetPlan, options: WriteOptions) -> None:
    """Before anything is written: the status is plausible and, where the offset acts
    at homing, the drive shows the home offset it holds with the profile's sign and
    word order (a homing with the old offset, checked). Raises DriverError
    (a PreflightError names the profile field).

    Not that homing before the restore of a write that did not finish: what the drive
    holds is that write's, whose own check at homing may be what failed (a home offset
    sign opposite the profile's, on a drive that homes where it stands); checked first,
    it refused the only way back to the values held before. The restore is checked at
    its own homing, with the old values."""
    check_identity(controller)
    if plan.facts.kind == "home_offset" and options.rehome and not plan.restores_unfinished:
        controller.enable()
        controller.home()
        check_home(controller)


@dataclass(frozen=True)
class _Written:
    """The write's outcome: the values read back and when they act."""

    back_mm: dict[str, float]
    takes_effect: str


def _check_can_write(plan: OffsetPlan, options: WriteOptions,
                     offsets_file: Path | None) -> None:
    """What the profile allows, before the controller is asked anything."""
    facts = plan.facts
    if facts.kind == "software" and offsets_file is None:
        raise WriteBackError(f"profile {facts.profile!r} has no offset register: the offsets go "
                             "into the software offset table, and the campaign file names none "
                             "([controller] offsets_file)", written=False)
    if options.save_nvm and not facts.has_nvm:
        raise WriteBackError(f"profile {facts.profile!r} has no non-volatile memory to save to "
                             "(its offsets persist in the software offset table)", written=False)


def _read_unmoved(controller: AxisController, plan: OffsetPlan) -> dict[str, float]:
    """The offsets held now, which must be those the plan was shown with."""
    now = controller.read_offsets()
    moved = {a: now[a] for a in AXES if not plan.facts.same(now[a], plan.current_mm[a])}
    if moved:
        raise WriteBackError(f"the controller's offsets changed since the plan was made "
                             f"(now {_fmt(moved)} mm): nothing written; show the plan again",
                             written=False)
    return now


def _record_intent(audit: AuditLog, plan: OffsetPlan, options: WriteOptions,
                   offsets_file: Path | None, now: dict[str, float]) -> str:
    """The intent, fsynced, before anything is written: its operation id."""
    operation = new_operation_id(plan.action)
    try:
        audit.record(Stage.INTENT, operation=operation, action=plan.action,
                     profile=plan.facts.profile, port=options.port, offset_kind=plan.facts.kind,
                     offsets_file=str(offsets_file) if offsets_file else None,
                     old_mm=now, new_mm=plan.new_mm, baseline_mm=plan.baseline_mm or None,
                     restores=plan.restores_operation, forced=list(options.forced),
                     refusals=[r.message for r in plan.refusals],
                     confirmed_by=options.confirmed_by, save_nvm=options.save_nvm,
                     rehome=options.rehome)
    except StorageError as exc:  # no write without the record of what to restore
        raise WriteBackError(f"{exc}: the intent record could not be written, so nothing "
                             "was written to the controller", written=False, disk=True) from None
    log.info("offsets %s: %s", operation,
             ", ".join(f"{c.axis} {c.current_mm:+.4f} -> {c.new_mm:+.4f} mm"
                       for c in plan.changes))
    return operation


def _disable_for_write(controller: AxisController, plan: OffsetPlan) -> list[str]:
    """Disable the drive where the profile writes offsets disabled: the axes that
    were on (to enable again when no homing follows)."""
    servo_on = [a for a, s in controller.read_status().items() if s.servo_on]
    if plan.facts.write_when_disabled and servo_on:
        controller.disable()
        return servo_on
    return []


def _write_and_read_back(controller: AxisController, plan: OffsetPlan, audit: AuditLog,
                         options: WriteOptions, offsets_file: Path | None) -> _Written:
    """Write, then read back (the registers, or the table re-read from disk) and compare
    within the storage step."""
    change = controller.write_offsets(plan.new_mm, force="beyond_margin" in options.forced)
    if plan.facts.kind == "software":
        assert offsets_file is not None
        back = write_offset_table(offsets_file, controller.software_offsets_mm,
                                  session=str(audit.session.path.resolve()),
                                  action=plan.action).offsets_mm
    else:
        back = controller.read_offsets()
    wrong = {a: back[a] for a in AXES if not plan.facts.same(back[a], plan.new_mm[a])}
    if wrong:
        raise DriverError(f"read back {_fmt(wrong)} mm after writing "
                          f"{_fmt({a: plan.new_mm[a] for a in wrong})} mm")
    return _Written(back, change.takes_effect)


def _check_home_positions(controller: AxisController, plan: OffsetPlan,
                          home_positions: dict[str, float], back_mm: dict[str, float]) -> None:
    """At the home point raw = 0, so q = -o: the new offset is in force."""
    tolerance = max(controller.profile.motion.in_position_band_mm, plan.facts.resolution_mm)
    off = {a: q for a, q in home_positions.items() if abs(q + back_mm[a]) > tolerance}
    if off:
        raise DriverError(f"after homing the axes read {_fmt(off)} mm at the home point, "
                          f"not minus the new offsets {_fmt({a: back_mm[a] for a in off})}")


def _record_failure(controller: AxisController, plan: OffsetPlan, audit: AuditLog,
                    offsets_file: Path | None, operation: str, exc: BaseException, *,
                    nvm_saved: bool, rehomed: bool) -> dict[str, float] | None:
    """The ``failed`` record with what the controller holds now (returned, None when
    it cannot be read)."""
    held = _held(controller, plan, offsets_file)
    error = str(exc) or type(exc).__name__
    # the intent (fsynced) already holds what restore needs, should the disk refuse this
    with contextlib.suppress(StorageError):
        audit.record(Stage.FAILED, operation=operation, action=plan.action, error=error,
                     held_mm=held, nvm_saved=nvm_saved, rehomed=rehomed)
    log.error("offsets %s failed: %s (held now: %s)", operation, error, held)
    return held


def _failure_error(plan: OffsetPlan, operation: str, exc: BaseException,
                   now: dict[str, float], held: dict[str, float] | None) -> WriteBackError:
    holds = _fmt(held) + " mm" if held else "unknown (read failed)"
    return WriteBackError(
        f"{plan.action} {operation} failed: {str(exc) or type(exc).__name__}. The controller "
        f"holds {holds}; the old values {_fmt(now)} mm are in the session "
        "(`ogacq offsets restore`)", written=True, operation=operation)


# What a failed write reports as a WriteBackError; anything else (a KeyboardInterrupt,
# a bug) is recorded as failed and propagates as it is.
_REPORTED = (DriverError, ValueError, OSError, InputError)


def _record_done(audit: AuditLog, plan: OffsetPlan, operation: str, outcome: WriteOutcome,
                 ) -> None:
    try:
        audit.record(Stage.DONE, operation=operation, action=plan.action, old_mm=outcome.old_mm,
                     new_mm=outcome.new_mm, takes_effect=outcome.takes_effect,
                     rehomed=outcome.rehomed, home_positions_mm=outcome.home_positions_mm,
                     nvm_saved=outcome.nvm_saved,
                     offsets_file=str(outcome.offsets_file) if outcome.offsets_file else None,
                     survives_power_cycle=outcome.survives_power_cycle)
    except StorageError as exc:
        raise WriteBackError(
            f"{plan.action} {operation}: the controller holds {_fmt(outcome.new_mm)} mm (read "
            f"back), but the session could not record it: {exc}. Its intent record holds the "
            f"old values {_fmt(outcome.old_mm)} mm (`ogacq offsets restore`)", written=True,
            operation=operation, disk=True) from None
    log.info("offsets %s done: %s mm (%s)", operation, _fmt(outcome.new_mm),
             outcome.takes_effect)


def execute_plan(controller: AxisController, plan: OffsetPlan, audit: AuditLog,
                 options: WriteOptions, *, offsets_file: Path | None = None) -> WriteOutcome:
    """Write ``plan`` (already approved: policy and operator) and verify it: checked,
    intent recorded, written and read back, saved, re-homed, outcome recorded."""
    _check_can_write(plan, options, offsets_file)
    now = _read_unmoved(controller, plan)
    operation = _record_intent(audit, plan, options, offsets_file, now)
    nvm_saved = rehomed = False  # how far it got, for the failure record
    home_positions: dict[str, float] | None = None
    try:
        servo_was_on = _disable_for_write(controller, plan)
        written = _write_and_read_back(controller, plan, audit, options, offsets_file)
        if options.save_nvm:
            controller.save_to_nvm()
            nvm_saved = True
        if written.takes_effect == "at_next_homing" and options.rehome:
            controller.enable()
            statuses = controller.home()
            rehomed = True
            home_positions = {a: s.position_mm for a, s in statuses.items()}
            _check_home_positions(controller, plan, home_positions, written.back_mm)
        elif servo_was_on:
            controller.enable(servo_was_on)
    except BaseException as exc:
        held = _record_failure(controller, plan, audit, offsets_file, operation, exc,
                               nvm_saved=nvm_saved, rehomed=rehomed)
        if not isinstance(exc, _REPORTED):
            raise
        raise _failure_error(plan, operation, exc, now, held) from exc
    outcome = WriteOutcome(operation, plan.action, now, written.back_mm, written.takes_effect,
                           rehomed, home_positions, nvm_saved, offsets_file)
    _record_done(audit, plan, operation, outcome)
    return outcome
