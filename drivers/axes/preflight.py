"""Pre-flight check: is the drive what the profile says, before anything moves further?

A profile with the wrong 32-bit word order passes every read-back (writes and
reads are swapped alike) while the drive is sent 65,536 times the target; a
profile with the wrong home-offset sign homes and runs silently off by twice
the offset. Neither shows in the client's own bookkeeping, so this module looks
where they do show:

1. ``check_identity`` (nothing moves): the status words form a pattern the
   family can show (a CiA 402 statusword is one of its state patterns; no axis
   is in position and moving at once), and the position read twice at rest
   agrees within one register step.
2. ``check_home`` (after a homing): the position reads the value the profile
   predicts at the home point (``offset.sign`` × home offset, 0 for a software
   offset table) within one register step. Reading the opposite value names
   ``offset.sign``; reading the value with swapped words names ``codec.word_order``.
3. ``probe_move`` (the first move): a small move of known size from home,
   polled on the way. With the words swapped, the first position read while the
   drive moves decodes far outside the way from start to target (a count in the
   low word becomes 65,536 counts in the high word): the axes are stopped at
   once and ``codec.word_order`` is named. On arrival the move must read back
   its size. A drive's own position limits may refuse the swapped target first
   (an alarm): that is reported with the same field.

What no Modbus read can show: a wrong ``codec.counts_per_mm`` that scales
commands and reads alike; the drive reads back consistent numbers. The
campaign's gauges see it (the diagnosis names an encoder scale error).

Every failure raises :class:`PreflightError`, one line naming the axis, what was
seen and the profile field to change; the caller stops before the next move.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Iterable

from ogacq_drivers.axes.controller import AxisController
from ogacq_drivers.errors import DeviceFault, DriverError

log = logging.getLogger(__name__)

#: CiA 402 statusword state patterns: (mask, value) [CiA 402-2 (IEC 61800-7-201),
#: statusword bits 0-3, 5, 6 "state coding" table].
CIA402_STATES = (
    (0x4F, 0x00, "not ready to switch on"),
    (0x4F, 0x40, "switch on disabled"),
    (0x6F, 0x21, "ready to switch on"),
    (0x6F, 0x23, "switched on"),
    (0x6F, 0x27, "operation enabled"),
    (0x6F, 0x07, "quick stop active"),
    (0x4F, 0x0F, "fault reaction active"),
    (0x4F, 0x08, "fault"),
)


class PreflightError(DeviceFault):
    """The drive is not what the profile says; names the profile field to change."""

    def __init__(self, message: str, *, field: str, where: str) -> None:
        super().__init__(message, code="preflight", where=where)
        self.field = field


def _step_mm(controller: AxisController) -> float:
    return 1.0 / controller.profile.codec.counts_per_mm


def check_identity(controller: AxisController, axes: Iterable[str] | None = None) -> None:
    """Status pattern plausible for the family; the position read twice agrees (at rest)."""
    profile = controller.profile
    for axis in controller.chosen_axes(axes):
        where = controller.where(axis)
        first = controller.read_status([axis])[axis]
        if profile.family == "cia402":
            word = int(controller.read_raw(axis, "statusword"))
            if not any(word & mask == value for mask, value, _ in CIA402_STATES):
                raise PreflightError(
                    f"pre-flight {axis}: statusword {word:#06x} is no CiA 402 state: the device "
                    f"is not a CiA 402 drive at these addresses (check the profile's "
                    f"values.statusword.address and axes.device_ids)",
                    field="values.statusword.address", where=where)
        if first.in_position and first.moving:
            # in position and moving at once: a status bit read from the wrong place
            raise PreflightError(
                f"pre-flight {axis}: the status says in position and moving at once: check "
                f"flags.in_position and flags.moving (and their registers) in profile "
                f"{profile.name!r}", field="flags.moving", where=where)
        second = controller.read_status([axis])[axis]
        if not (first.moving or second.moving) and \
                abs(first.position_mm - second.position_mm) > _step_mm(controller) + 1e-9:
            raise PreflightError(
                f"pre-flight {axis}: position read twice at rest gave {first.position_mm:.4f} "
                f"and {second.position_mm:.4f} mm: check values.{profile.status.position}."
                "address and codec.word_order",
                field="codec.word_order", where=where)


def check_home(controller: AxisController, axes: Iterable[str] | None = None) -> None:
    """After a homing: the position is the value the profile predicts at the home point."""
    profile = controller.profile
    step = _step_mm(controller) + 1e-9
    for axis in controller.chosen_axes(axes):
        where = controller.where(axis)
        expected = controller.counter_at_home_mm(axis)
        status = controller.read_status([axis])[axis]
        seen = controller.counter_mm(status)
        if abs(seen - expected) <= step:
            if expected == 0.0 and profile.offset.kind == "home_offset":
                log.info("%s: home offset is 0: its sign (offset.sign) is checked at the next "
                         "homing with a non-zero offset", where)
            continue
        if profile.offset.kind == "home_offset" and abs(seen + expected) <= step:
            raise PreflightError(
                f"pre-flight {axis}: after homing the drive reads {seen:+.4f} mm at the home "
                f"point, the opposite of the {expected:+.4f} mm the profile predicts: change "
                f"offset.sign to {-profile.offset.sign:+d} in profile {profile.name!r}",
                field="offset.sign", where=where)
        raise PreflightError(
            f"pre-flight {axis}: after homing the drive reads {seen:+.4f} mm at the home point, "
            f"not the {expected:+.4f} mm the profile predicts: check codec.word_order and "
            f"offset.sign in profile {profile.name!r}",
            field="codec.word_order", where=where)


def probe_move(controller: AxisController, probe_mm: float = 1.0,
               axes: Iterable[str] | None = None, *, timeout_s: float | None = None) -> None:
    """A first small move of known size, watched on the way; stops the axes on a mismatch."""
    profile = controller.profile
    chosen = controller.chosen_axes(axes)
    start = {a: s.position_mm for a, s in controller.read_status(chosen).items()}
    low, high = controller.soft_limits_mm
    targets = {a: q + probe_mm if q + probe_mm <= high else q - probe_mm
               for a, q in start.items()}
    if any(not low <= t <= high for t in targets.values()):
        raise ValueError(f"pre-flight: no room for a {probe_mm} mm probe move within "
                         f"the soft limits [{low:g}, {high:g}] mm")
    slack = max(_step_mm(controller), profile.motion.in_position_band_mm) + 1e-9
    speed = controller.speed_mm_s
    limit = timeout_s or (10.0 + 5.0 * probe_mm / speed)
    try:
        controller.move_to(targets, wait=False)
    except DeviceFault as exc:
        said = str(exc).removeprefix(f"{exc.where}: ")
        raise PreflightError(
            f"pre-flight: the drive refused the {probe_mm:g} mm probe move ({said}); a "
            f"wrong 32-bit word order sends 65,536 times the target: change "
            f"codec.word_order in profile {profile.name!r} (or check the drive's limits)",
            field="codec.word_order", where=exc.where) from exc
    deadline = time.monotonic() + limit
    done: set[str] = set()
    while len(done) < len(chosen):
        for axis in [a for a in chosen if a not in done]:
            try:
                status = controller.read_status([axis])[axis]
            except DriverError:
                controller.stop_quietly(chosen)
                raise
            q = status.position_mm
            lo, hi = sorted((start[axis], targets[axis]))
            if not lo - slack <= q <= hi + slack or status.fault:
                controller.stop_quietly(chosen)
                seen = (f"alarm {status.alarm_code:#x}" if status.fault
                        else f"position {q:+.4f} mm")
                raise PreflightError(
                    f"pre-flight {axis}: during a {probe_mm:g} mm probe move from "
                    f"{start[axis]:+.4f} mm the drive showed {seen}, outside the way to "
                    f"{targets[axis]:+.4f} mm: the 32-bit word order is wrong; change "
                    f"codec.word_order in profile {profile.name!r}",
                    field="codec.word_order", where=controller.where(axis))
            if status.in_position and not status.moving and abs(q - targets[axis]) <= slack:
                done.add(axis)
        if len(done) < len(chosen):
            if time.monotonic() > deadline:
                controller.stop_quietly(chosen)
                raise PreflightError(
                    f"pre-flight: the {probe_mm:g} mm probe move did not arrive within "
                    f"{limit:.0f} s: check codec.counts_per_mm and codec.word_order in profile "
                    f"{profile.name!r}", field="codec.counts_per_mm",
                    where=controller.where(chosen[0]))
            time.sleep(controller.poll_interval_s)
    log.info("pre-flight: probe move of %g mm read back on %s", probe_mm, ", ".join(chosen))


def run_preflight(controller: AxisController, *, probe_mm: float = 1.0) -> None:
    """All checks, for axes enabled and just homed: identity, home value, probe move."""
    check_identity(controller)
    check_home(controller)
    probe_move(controller, probe_mm)
