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
import logging
from dataclasses import dataclass
from pathlib import Path

from ogacq_drivers.axes.controller import AxisController
from ogacq_drivers.axes.preflight import check_home, check_identity
from ogacq_drivers.errors import DriverError
from ogacq.io.errors import InputError, StorageError
from ogacq.model.parameters import AXES
from ogacq.model.units import signed_per_axis as _fmt
from ogacq.writeback.audit import AuditLog, new_operation_id
from ogacq.writeback.policy import OffsetPlan
from ogacq.writeback.table import read_offset_table, write_offset_table

log = logging.getLogger(__name__)


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
    (a PreflightError names the profile field)."""
    check_identity(controller)
    if plan.facts.kind == "home_offset" and options.rehome:
        controller.enable()
        controller.home()
        check_home(controller)


def execute_plan(controller: AxisController, plan: OffsetPlan, audit: AuditLog,
                 options: WriteOptions, *, offsets_file: Path | None = None) -> WriteOutcome:
    """Write ``plan`` (already approved: policy and operator) and verify it."""
    facts = plan.facts
    if facts.kind == "software" and offsets_file is None:
        raise WriteBackError(f"profile {facts.profile!r} has no offset register: the offsets go "
                             "into the software offset table, and the campaign file names none "
                             "([controller] offsets_file)", written=False)
    if options.save_nvm and not facts.has_nvm:
        raise WriteBackError(f"profile {facts.profile!r} has no non-volatile memory to save to "
                             "(its offsets persist in the software offset table)", written=False)
    now = controller.read_offsets()
    moved = {a: now[a] for a in AXES if not facts.same(now[a], plan.current_mm[a])}
    if moved:
        raise WriteBackError(f"the controller's offsets changed since the plan was made "
                             f"(now {_fmt(moved)} mm): nothing written; show the plan again",
                             written=False)

    operation = new_operation_id(plan.action)
    try:
        audit.record("intent", operation=operation, action=plan.action, profile=facts.profile,
                     port=options.port, offset_kind=facts.kind,
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
    nvm_saved = False
    rehomed = False
    home_positions: dict[str, float] | None = None
    try:
        servo_was_on = {a: s.servo_on for a, s in controller.read_status().items()}
        if facts.write_when_disabled and any(servo_was_on.values()):
            controller.disable()
        change = controller.write_offsets(plan.new_mm, force="beyond_margin" in options.forced)
        if facts.kind == "software":
            assert offsets_file is not None
            back = write_offset_table(offsets_file, controller.software_offsets_mm,
                                      session=str(audit.session.path.resolve()),
                                      action=plan.action).offsets_mm
        else:
            back = controller.read_offsets()
        wrong = {a: back[a] for a in AXES if not facts.same(back[a], plan.new_mm[a])}
        if wrong:
            raise DriverError(f"read back {_fmt(wrong)} mm after writing "
                              f"{_fmt({a: plan.new_mm[a] for a in wrong})} mm")
        if options.save_nvm:
            controller.save_to_nvm()
            nvm_saved = True
        if change.takes_effect == "at_next_homing" and options.rehome:
            controller.enable()
            statuses = controller.home()
            rehomed = True
            home_positions = {a: s.position_mm for a, s in statuses.items()}
            # at the home point raw = 0, so q = -o: the new offset is in force
            tolerance = max(controller.profile.motion.in_position_band_mm, facts.resolution_mm)
            off = {a: q for a, q in home_positions.items() if abs(q + back[a]) > tolerance}
            if off:
                raise DriverError(f"after homing the axes read {_fmt(off)} mm at the home point, "
                                  f"not minus the new offsets {_fmt({a: back[a] for a in off})}")
        elif facts.write_when_disabled and any(servo_was_on.values()):
            controller.enable([a for a, on in servo_was_on.items() if on])
    except BaseException as exc:
        held = _held(controller, plan, offsets_file)
        error = str(exc) or type(exc).__name__
        # the intent (fsynced) already holds what restore needs, should the disk refuse this
        with contextlib.suppress(StorageError):
            audit.record("failed", operation=operation, action=plan.action, error=error,
                         held_mm=held, nvm_saved=nvm_saved, rehomed=rehomed)
        log.error("offsets %s failed: %s (held now: %s)", operation, error, held)
        if not isinstance(exc, DriverError | ValueError | OSError | InputError):
            raise
        holds = _fmt(held) + " mm" if held else "unknown (read failed)"
        raise WriteBackError(
            f"{plan.action} {operation} failed: {error}. The controller holds {holds}; the "
            f"old values {_fmt(now)} mm are in the session (`ogacq offsets restore`)",
            written=True, operation=operation) from exc

    try:
        audit.record("done", operation=operation, action=plan.action, old_mm=now, new_mm=back,
                     takes_effect=change.takes_effect, rehomed=rehomed,
                     home_positions_mm=home_positions, nvm_saved=nvm_saved,
                     offsets_file=str(offsets_file) if offsets_file else None,
                     survives_power_cycle=offsets_file is not None or nvm_saved)
    except StorageError as exc:
        raise WriteBackError(
            f"{plan.action} {operation}: the controller holds {_fmt(back)} mm (read back), but "
            f"the session could not record it: {exc}. Its intent record holds the old values "
            f"{_fmt(now)} mm (`ogacq offsets restore`)", written=True,
            operation=operation, disk=True) from None
    log.info("offsets %s done: %s mm (%s)", operation, _fmt(back), change.takes_effect)
    return WriteOutcome(operation, plan.action, now, back, change.takes_effect, rehomed,
                        home_positions, nvm_saved, offsets_file)
