"""Pre-flight check: is the drive what the profile says, before any set-point?

A profile with the wrong 32-bit word order passes every read-back (writes and
reads are swapped alike) while the drive is sent 65,536 times the target; a
profile with the wrong home-offset sign homes and runs silently off by twice
the offset. Neither shows in the client's own bookkeeping, so this module looks
where they do show, and before anything is commanded that could lurch:

1. ``check_identity`` (nothing moves, before homing): a 32-bit register whose value
   the drive's kind fixes (``[word_order_check]``: CiA 402's device type, profile
   number 402 in its low word) reads it in the profile's word order; the status words form a
   pattern the family can show (a CiA 402 statusword is one of its state
   patterns; no axis is in position and moving at once); the position read
   twice at rest agrees within one register step; and every 32-bit value read
   (position, home offset) is plausible for the machine: no further from 0
   than its whole travel (soft limits and their margins). A value of 1 count
   and more read with its words swapped is 65,536 counts and more (655 mm at
   100 counts/mm): the refusal names ``codec.word_order`` and shows what the
   words would read the other way round. Homing is the drive's own motion (its
   method and speeds are its parameters), so it is safe with any codec; these
   reads come first all the same, so that a wrong home offset is not applied.
2. ``check_home`` (after a homing): the position reads the value the profile
   predicts at the home point (``offset.sign`` × home offset, 0 for a software
   offset table) within one register step. Reading the opposite value names
   ``offset.sign``; any other names ``codec.word_order``.
3. ``probe_move`` (the first set-point): a small move of known size from home
   at a speed of exactly 65,536 counts/s (0x00010000). In the profile's word
   order that is the drive's fast speed for a 1 mm move; with the words swapped
   the drive reads 1 count/s, so the far target it also misreads is crept
   towards one count at a time, and the first count moved decodes as 65,536
   (far outside the way): the axes are stopped at once, a count or two from
   where they were, and ``codec.word_order`` is named. A drive's own position
   limits may refuse the swapped target first (an alarm): the same field.

Only an axis that stands at counter 0 (or -1) with a home offset of 0 reads the
same in both word orders; then the probe's speed is what bounds a mistake.
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
from dataclasses import dataclass

from ogacq_drivers.axes.cia402 import drive_state
from ogacq_drivers.axes.controller import AxisController
from ogacq_drivers.axes.profile import (
    Profile,
    counts_to_mm,
    int_to_words,
    mm_to_counts,
    words_to_int,
)
from ogacq_drivers.errors import DeviceFault, DriverError, PreflightError

log = logging.getLogger(__name__)

#: The probe's speed in counts/s: 0x00010000, whose words swapped read 0x00000001.
PROBE_SPEED_COUNTS_S = 0x10000


def _step_mm(controller: AxisController) -> float:
    return 1.0 / controller.profile.codec.counts_per_mm


def travel_bound_mm(controller: AxisController) -> float:
    """The furthest from 0 any position or offset of this machine can read: its whole
    travel, soft limits and their margins (an incremental counter started anywhere on
    the axis stays within it; a homed one stays within the limits)."""
    low, high = controller.soft_limits_mm
    return (high - low) + 2.0 * controller.profile.limits.margin_mm


def _swapped_mm(profile: Profile, name: str, value_mm: float) -> float | None:
    """What ``value_mm`` of 32-bit value ``name`` reads with its two words the other way
    round (None for a 16-bit value or one that cannot be encoded)."""
    spec = profile.value(name)
    scale = profile.scale_of(spec)
    if spec.words != 2 or scale is None:
        return None
    try:
        words = int_to_words(mm_to_counts(value_mm, scale), 2,
                             word_order=profile.codec.word_order, signed=spec.signed)
    except ValueError:
        return None
    return counts_to_mm(words_to_int(words[::-1], word_order=profile.codec.word_order,
                                     signed=spec.signed), scale)


def check_plausible(controller: AxisController, axes: Iterable[str] | None = None) -> None:
    """Every 32-bit value the client reads at rest (position, home offset) within the
    machine's whole travel; else the words are read in the wrong order (or the scale
    is wrong): refused before homing, before any set-point."""
    profile = controller.profile
    bound = travel_bound_mm(controller)
    names = [profile.status.position]
    if profile.offset.kind == "home_offset":
        names.append(profile.offset.value)
    for axis in controller.chosen_axes(axes):
        for name in names:
            value = float(controller.read_raw(axis, name))
            if abs(value) <= bound:
                continue
            swapped = _swapped_mm(profile, name, value)
            other = "" if swapped is None else (
                f"; with its words the other way round it reads {swapped:+.2f} mm")
            plausible = swapped is not None and abs(swapped) <= bound
            raise PreflightError(
                f"pre-flight {axis}: {name} reads {value:+,.2f} mm at rest, "
                f"{abs(value) / bound:,.0f} times the machine's whole travel of {bound:g} mm"
                f"{other}: " + (
                    f"change codec.word_order (now {profile.codec.word_order!r}) in profile "
                    f"{profile.name!r}" if plausible else
                    f"check codec.word_order (now {profile.codec.word_order!r}) and "
                    f"codec.counts_per_mm in profile {profile.name!r}")
                + "; nothing was commanded",
                field="codec.word_order", where=controller.where(axis))


def _swap_words(value: int) -> int:
    return ((value & 0xFFFF) << 16) | (value >> 16 & 0xFFFF)


def check_word_order(controller: AxisController, axes: Iterable[str] | None = None) -> None:
    """The profile's ``[word_order_check]`` register holds the value the drive's kind fixes
    in the profile's word order: refused, naming ``codec.word_order``, when it does so
    only with the words the other way round; nothing is written or moved. (Without such
    a register the word order shows only in a value far from 0, :func:`check_plausible`,
    or, where every value read is 0 or -1, in the probe move.)"""
    profile = controller.profile
    check = profile.word_order_check
    if check is None:
        return
    for axis in controller.chosen_axes(axes):
        value = int(controller.read_raw(axis, check.value)) & 0xFFFFFFFF
        if value & check.mask == check.equals:
            continue
        swapped = _swap_words(value)
        reads = (f"pre-flight {axis}: {check.value} reads {value:#010x}, not the "
                 f"{check.equals:#x} (mask {check.mask:#x}) a drive of this kind holds")
        if swapped & check.mask == check.equals:
            raise PreflightError(
                f"{reads}; with its words the other way round it reads {swapped:#010x}: change "
                f"codec.word_order (now {profile.codec.word_order!r}) in profile "
                f"{profile.name!r}; nothing was commanded",
                field="codec.word_order", where=controller.where(axis))
        raise PreflightError(
            f"{reads}: check values.{check.value}.address and axes.device_ids in profile "
            f"{profile.name!r} (or delete [word_order_check] for a drive that does not map "
            "it); nothing was commanded",
            field=f"values.{check.value}.address", where=controller.where(axis))


def check_identity(controller: AxisController, axes: Iterable[str] | None = None) -> None:
    """Status pattern plausible for the family; the position read twice agrees (at rest);
    every 32-bit value within the machine's travel (:func:`check_plausible`); the word
    order of the profile's known value (:func:`check_word_order`)."""
    profile = controller.profile
    for axis in controller.chosen_axes(axes):
        where = controller.where(axis)
        first = controller.read_status([axis])[axis]
        if profile.family == "cia402":
            word = int(controller.read_raw(axis, "statusword"))
            if drive_state(word) is None:
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
    check_plausible(controller, axes)
    check_word_order(controller, axes)


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


def probe_speed_mm_s(controller: AxisController) -> float:
    """The probe's speed: 65,536 counts/s in the profile's units (1 count/s swapped)."""
    return PROBE_SPEED_COUNTS_S / controller.profile.codec.speed_counts_per_mm_s


def probe_move(controller: AxisController, probe_mm: float = 1.0,
               axes: Iterable[str] | None = None, *, timeout_s: float | None = None) -> None:
    """A first small move of known size, watched on the way; stops the axes on a mismatch.
    Its speed (:func:`probe_speed_mm_s`) reads 1 count/s with the words swapped, so a
    wrong word order creeps, is seen at its first count, and is stopped there."""
    profile = controller.profile
    chosen = controller.chosen_axes(axes)
    start = {a: s.position_mm for a, s in controller.read_status(chosen).items()}
    targets = _probe_targets(controller, start, probe_mm)
    probe = _Probe(controller, chosen, start, targets, probe_mm)
    speed = probe_speed_mm_s(controller)
    # the right word order arrives in a blink (the drive's own ramps and speed limit
    # aside); the wrong one moves one count a second and is seen at its first
    limit = timeout_s or 10.0
    try:
        controller.move_to(targets, wait=False, speed_mm_s=speed)
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
        done |= {axis for axis in chosen if axis not in done and probe.arrived(axis)}
        if len(done) < len(chosen):
            if time.monotonic() > deadline:
                controller.stop_quietly(chosen)
                raise PreflightError(
                    f"pre-flight: the {probe_mm:g} mm probe move at {speed:g} mm/s did not "
                    f"arrive within {limit:.0f} s: a drive that reads its speed with the "
                    f"words swapped creeps at 1 count/s; check codec.word_order (and "
                    f"codec.counts_per_mm, codec.speed_counts_per_mm_s) in profile "
                    f"{profile.name!r}", field="codec.word_order",
                    where=controller.where(chosen[0]))
            time.sleep(controller.poll_interval_s)
    log.info("pre-flight: probe move of %g mm read back on %s", probe_mm, ", ".join(chosen))


def _probe_targets(controller: AxisController, start: dict[str, float],
                   probe_mm: float) -> dict[str, float]:
    """Each axis ``probe_mm`` up, or down where up leaves the soft limits."""
    low, high = controller.soft_limits_mm
    targets = {a: q + probe_mm if q + probe_mm <= high else q - probe_mm
               for a, q in start.items()}
    if any(not low <= t <= high for t in targets.values()):
        raise ValueError(f"pre-flight: no room for a {probe_mm} mm probe move within "
                         f"the soft limits [{low:g}, {high:g}] mm")
    return targets


@dataclass(frozen=True)
class _Probe:
    """A probe move under way, watched axis by axis."""

    controller: AxisController
    chosen: tuple[str, ...]
    start: dict[str, float]
    targets: dict[str, float]
    probe_mm: float

    def arrived(self, axis: str) -> bool:
        """Whether the axis is at its target; every axis stopped, and the word order
        named, when it reads off the way from its start to its target or in alarm."""
        controller, start, target = self.controller, self.start[axis], self.targets[axis]
        try:
            status = controller.read_status([axis])[axis]
        except DriverError:
            controller.stop_quietly(self.chosen)
            raise
        q, slack = status.position_mm, controller.position_tolerance_mm()
        lo, hi = sorted((start, target))
        if not lo - slack <= q <= hi + slack or status.fault:
            controller.stop_quietly(self.chosen)
            seen = (f"alarm {status.alarm_code:#x}" if status.fault
                    else f"position {q:+.4f} mm")
            raise PreflightError(
                f"pre-flight {axis}: during a {self.probe_mm:g} mm probe move from "
                f"{start:+.4f} mm the drive showed {seen}, outside the way to "
                f"{target:+.4f} mm: the 32-bit word order is wrong; change "
                f"codec.word_order in profile {controller.profile.name!r}",
                field="codec.word_order", where=controller.where(axis))
        return status.in_position and not status.moving and abs(q - target) <= slack


def run_preflight(controller: AxisController, *, probe_mm: float = 1.0) -> None:
    """All checks, for axes enabled and just homed: identity, home value, probe move.
    (A campaign runs :func:`check_identity` before its homing too.)"""
    check_identity(controller)
    check_home(controller)
    probe_move(controller, probe_mm)
