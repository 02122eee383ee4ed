"""Client for the three linear axes (x, y, z) of the machine, driven by a register-map profile.

Coordinates: ``q`` is the joint coordinate in mm used by the kinematic model.
Homing puts each axis at its home point ``p = 0`` (``p``: position from the
home point, the simulator's ``raw_position_mm``). The joint zero offsets ``o``
(one per axis) relate the two, the same way for every profile:

    q = p - o        (a move to q goes to p = q + o)

- ``offset.kind = "software"`` (IAI): the offsets live in a table in this
  client (the tool's configuration keeps it); the controller counts ``p`` and
  the client adds ``o`` to every commanded position and subtracts it from every
  position read.
- ``offset.kind = "home_offset"`` (CiA 402): ``o`` is held by the drive's home
  offset object, which the drive applies at its next homing (its position at
  the home point becomes ``sign × object = -o``), so the drive counts ``q``
  itself and this client adds nothing. ``write_offsets`` writes the object
  (read back and compared); :meth:`AxisController.home` makes it effective.

Commands are the profile's step sequences (see ``profiles/iai-pcon.toml``).
Edge-triggered writes (home, move start) are sent once and confirmed by
reading back (moving bit, set-point acknowledge or arrival at the target);
a missing confirmation raises rather than re-sending. Every write is logged by
the link. A step marked ``skip_unchanged`` (a mode or speed the drive keeps)
is not re-sent when this client's last write of that object was the same
value; that memory is dropped on any fault seen, failed transaction, alarm
reset, enable, disable or homing, after which the device's state is not
known. The controller is not thread-safe: one caller at a time.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from numbers import Real
from typing import Any, Literal

from ogacq_drivers.axes.cia402 import (
    MOST_TRANSITIONS,
    TARGET_REACHED,
    TOWARDS_OPERATION,
    DriveState,
    drive_state,
)
from ogacq_drivers.axes.modbus_link import ModbusLink
from ogacq_drivers.axes.profile import CommandStep, Profile, ValueSpec, counts_to_mm, mm_to_counts
from ogacq_drivers.errors import DeviceFault, DeviceTimeout, DriverError, PreflightError

log = logging.getLogger(__name__)

Targets = Mapping[str, float] | Sequence[float]
#: Registers one FC 3 request may read (Modbus Application Protocol V1.1b3 §6.3).
MAX_READ_REGISTERS = 125


@dataclass(frozen=True)
class AxisStatus:
    """One axis at one poll. ``position_mm`` is the joint coordinate q (offsets removed)."""

    axis: str
    position_mm: float
    in_position: bool
    moving: bool
    servo_on: bool
    homed: bool
    alarm_code: int
    fault: bool
    flags: Mapping[str, bool] = field(default_factory=dict, compare=False, repr=False)


@dataclass(frozen=True)
class OffsetChange:
    """What :meth:`AxisController.write_offsets` did, for the session record and undo."""

    old_mm: dict[str, float]
    new_mm: dict[str, float]
    takes_effect: Literal["now", "at_next_homing"]
    written_to_device: bool


@dataclass(frozen=True)
class _Poll:
    """One read of an axis's status registers: all of them, or the flag words only."""

    axis: str
    flags: Mapping[str, bool]
    fault: bool
    alarm_code: int
    homed: bool
    position_mm: float | None  # None when only the flag words were read

    @property
    def settled(self) -> bool:
        """In position and not moving."""
        return self.flags["in_position"] and not self.flags["moving"]


@dataclass(frozen=True)
class _Block:
    """One read request of contiguous holding registers and the values inside it."""

    address: int
    count: int
    names: tuple[str, ...]


def _soft_limits(profile: Profile, given: tuple[float, float] | None) -> tuple[float, float]:
    """The station's soft limits, else the profile's; refused when empty."""
    low, high = given or (profile.limits.min_mm, profile.limits.max_mm)
    if not low < high:
        raise ValueError(f"soft limits [{low}, {high}] mm are empty")
    return float(low), float(high)


class AxisController:
    """Enable, home, move, poll, stop, reset alarms and handle joint offsets of three axes."""

    def __init__(self, profile: Profile, link: ModbusLink | Mapping[str, ModbusLink], *,
                 axes: Iterable[str] | None = None, device_ids: Mapping[str, int] | None = None,
                 software_offsets_mm: Mapping[str, float] | None = None,
                 soft_limits_mm: tuple[float, float] | None = None, speed_mm_s: float | None = None,
                 poll_interval_s: float = 0.002) -> None:
        self.profile = profile
        self.axes: tuple[str, ...] = tuple(axes) if axes is not None else tuple(profile.device_ids)
        #: Modbus unit id per axis: the profile's, unless the station gives its own.
        self.device_ids = {**profile.device_ids, **dict(device_ids or {})}
        unknown = [a for a in self.axes if a not in self.device_ids]
        if unknown:
            raise ValueError(f"profile {profile.name!r} has no device id for axes {unknown}")
        self._links = self._links_of(link)
        #: The first axis's link (all of them where the axes share one).
        self.link = self._links[self.axes[0]]
        for axis in self.axes:
            self._links[axis].check_device_id(self.device_ids[axis])
        self.soft_limits_mm = _soft_limits(profile, soft_limits_mm)
        self.speed_mm_s = speed_mm_s or profile.motion.speed_mm_s
        self.poll_interval_s = poll_interval_s
        self._software_offsets = self._software_offsets_of(software_offsets_mm)
        # Set once this client saw a homing through; used where the profile has no homed
        # bit, and only while the drive was never out of reach since (it may have been
        # switched off and on: an incremental encoder then counts from anywhere).
        self._homed_latch = {a: False for a in self.axes}
        self._losses_at_home = {a: 0 for a in self.axes}
        # Whether this client itself switched the axis's power stage off (disable, stop,
        # alarm reset) since it last enabled it. A drive seen with its servo off that this
        # client did not switch off was switched off and on, or faulted: a drive with no
        # homed flag then counts as unhomed (see _make_poll).
        self._servo_off_by_client = {a: True for a in self.axes}
        #: Axes whose home offset was written but not yet made effective by a homing.
        self.rehome_required: set[str] = set()
        self._blocks = self._plan_reads(self.profile.status_values())
        self._flag_blocks, self._position_blocks = self._flag_and_position_blocks()
        # (axis, value name) -> registers (or coil state) this client last wrote there.
        self._written: dict[tuple[str, str], tuple[int | bool, ...]] = {}
        # Joint coordinate each axis was last seen at (any status read with its position):
        # only to start the longest move first, never to decide anything else.
        self._last_seen_q: dict[str, float] = {}
        self._written_failures = 0

    def _links_of(self, link: ModbusLink | Mapping[str, ModbusLink]) -> dict[str, ModbusLink]:
        """One link for all axes (one bus or gateway), or one per axis (a drive per
        address)."""
        if isinstance(link, ModbusLink):
            return dict.fromkeys(self.axes, link)
        missing = [a for a in self.axes if a not in link]
        if missing:
            raise ValueError(f"no Modbus endpoint for axes {missing}")
        return {a: link[a] for a in self.axes}

    def _software_offsets_of(self, given: Mapping[str, float] | None) -> dict[str, float]:
        """The software offset table's values per axis (0 where none is given); only a
        profile that keeps its offsets in software has one."""
        offsets = dict.fromkeys(self.axes, 0.0)
        if given:
            if self.profile.offset.kind != "software":
                raise ValueError(f"profile {self.profile.name!r} keeps offsets in the drive "
                                 f"({self.profile.offset.kind}); a software offset table does "
                                 "not apply")
            offsets.update(self._per_axis(given, "software offsets"))
        return offsets

    def _flag_and_position_blocks(self) -> tuple[list[_Block], list[_Block]]:
        """The reads that poll an axis's flags, and those of its position: apart only
        where polling the flags alone saves requests (the position sits apart)."""
        position = self.profile.status.position
        flag_blocks = self._plan_reads([v for v in self.profile.status_values()
                                        if v != position])
        if len(flag_blocks) < len(self._blocks):
            return flag_blocks, self._plan_reads([position])
        return self._blocks, []

    @property
    def links(self) -> tuple[ModbusLink, ...]:
        """Every distinct link: one for a shared bus or gateway, else one per drive."""
        return tuple({id(k): k for k in self._links.values()}.values())

    def link_of(self, axis: str) -> ModbusLink:
        """The link the axis's drive is reached through."""
        return self._links[axis]

    # ================================================================ status

    def read_status(self, axes: Iterable[str] | None = None) -> dict[str, AxisStatus]:
        """Status of each axis: one block read per contiguous register run and device."""
        return {axis: self._status(axis) for axis in self.chosen_axes(axes)}

    @property
    def status_reads(self) -> tuple[tuple[int, int], ...]:
        """(address, register count) of the holding-register reads one axis status takes."""
        return tuple((b.address, b.count) for b in self._blocks)

    def read_positions(self, axes: Iterable[str] | None = None) -> dict[str, float]:
        """Joint coordinates q in mm (one position read per axis)."""
        name = self.profile.status.position
        return {axis: self._counter_to_q(axis, float(self.read_raw(axis, name)))
                for axis in self.chosen_axes(axes)}

    def read_alarms(self, axes: Iterable[str] | None = None) -> dict[str, int]:
        """Alarm / error code per axis (0 = none)."""
        name = self.profile.status.alarm_code
        return {axis: int(self.read_raw(axis, name)) for axis in self.chosen_axes(axes)}

    # ================================================================ commands

    def enable(self, axes: Iterable[str] | None = None, *, timeout_s: float | None = None) -> None:
        """Servo on (and whatever the profile needs before: Modbus control, CiA 402 states)."""
        chosen = self.chosen_axes(axes)
        self._forget_written(chosen)
        # Look before switching on: a drive that went off without this client's doing
        # (switched off and on between two polls) must be seen off, or the homing latch
        # of a drive with no homed flag would outlive its reference.
        for axis in chosen:
            self._poll(axis, self._flag_blocks)
        self._run("enable", chosen, common={"enable_timeout_s": timeout_s})
        for axis in chosen:
            self._servo_off_by_client[axis] = False

    def disable(self, axes: Iterable[str] | None = None, *, timeout_s: float | None = None) -> None:
        """Servo off."""
        chosen = self.chosen_axes(axes)
        self._forget_written(chosen)
        for axis in chosen:
            self._servo_off_by_client[axis] = True
        self._run("disable", chosen, common={"enable_timeout_s": timeout_s})

    def home(self, axes: Iterable[str] | None = None, *,
             timeout_s: float | None = None) -> dict[str, AxisStatus]:
        """Home the axes together and wait for the home end; applies a pending home offset."""
        chosen = self.chosen_axes(axes)
        self._forget_written(chosen)
        params: dict[str, dict[str, Any]] = {}
        for axis in chosen:
            self._homed_latch[axis] = False
            params[axis] = {"home_position_mm": self.counter_at_home_mm(axis),
                            "home_timeout_s": timeout_s}
        self._run("home", chosen, per_axis=params)
        for axis in chosen:
            self._homed_latch[axis] = True
            self._losses_at_home[axis] = self._links[axis].stats.losses
            self.rehome_required.discard(axis)
        log.info("homed axes %s", ", ".join(chosen))
        return self.read_status(chosen)

    def move_to(self, targets_mm: Targets, *, speed_mm_s: float | None = None, wait: bool = True,
                timeout_s: float | None = None, check_limits: bool = True,
                require_homed: bool = True) -> dict[str, AxisStatus]:
        """Absolute move of one or several axes to joint coordinates q (mm), together.

        ``targets_mm`` is ``{"x": 60.0, ...}`` or a sequence aligned with ``axes``.
        Targets outside the soft limits are refused before anything is sent
        (``check_limits=False`` leaves the check to the controller's own limits).
        With ``wait``, returns the statuses once every axis is in position at its
        target; without, returns the statuses read just before the move started."""
        targets = self._targets(targets_mm)
        if check_limits:
            low, high = self.soft_limits_mm
            for axis, q in targets.items():
                if not low <= q <= high:
                    raise ValueError(f"{self.where(axis)}: move {axis} to {q:.3f} mm refused: "
                                     f"outside the soft limits [{low:g}, {high:g}] mm")
        # Waiting, the positions are read on arrival: the check needs the flags only.
        blocks = self._flag_blocks if wait else self._blocks
        before = {axis: self._poll(axis, blocks) for axis in targets}
        for axis, status in before.items():
            if status.fault:
                raise self._fault(axis, f"move {axis} refused: axis in alarm "
                                  f"{status.alarm_code:#x}; reset alarms first", status.alarm_code)
            if not status.flags["servo_on"] or not status.flags.get("quick_stop", True):
                # CiA 402 "quick stop active" keeps bit 2 (operation enabled) set but
                # takes no set-point: a stop, not a state to move from
                raise self._fault(axis, f"move {axis} refused: servo is off (or the drive is "
                                  "in quick stop); enable first", "servo_off")
            if require_homed and not status.homed:
                raise self._fault(axis, f"move {axis} refused: axis not homed; home first",
                                  "not_homed")
        speed = speed_mm_s or self.speed_mm_s
        params = {axis: {"target_mm": self._q_to_counter(axis, q), "speed_mm_s": speed}
                  for axis, q in targets.items()}
        log.info("move %s at %.1f mm/s", ", ".join(f"{a}={q:.3f}" for a, q in targets.items()),
                 speed)
        try:
            self._run("move", self._longest_travel_first(targets), per_axis=params)
            if not wait:
                return {axis: self._as_status(poll) for axis, poll in before.items()}
            return self.wait_in_position(targets, timeout_s=timeout_s, require_homed=require_homed)
        except DriverError:
            # The axes start together: one failing must not leave the others going.
            self.stop_quietly(tuple(targets))
            raise

    def _longest_travel_first(self, targets: Mapping[str, float]) -> tuple[str, ...]:
        """The axes in the order their moves are started: the longest travel first.

        Every axis was checked before any is started, and they are started one
        request after the other; the move ends when its longest travel does, so
        starting that one first takes the other axes' start requests off the time
        the move takes (two to four Modbus round trips a move). An axis whose last
        position is unknown keeps its place (a stable sort), as before."""
        def travel(axis: str) -> float:
            last = self._last_seen_q.get(axis)
            return 0.0 if last is None else abs(targets[axis] - last)

        return tuple(sorted(targets, key=travel, reverse=True))

    def resolved_targets_mm(self, targets_mm: Targets) -> dict[str, float]:
        """The joint coordinates a move to ``targets_mm`` really commands: each target
        rounded to the controller's position resolution (``codec.counts_per_mm``).
        A calibration must record these, not the unrounded wish."""
        counts_per_mm = self.profile.codec.counts_per_mm
        return {axis: self._counter_to_q(axis, counts_to_mm(
                    mm_to_counts(self._q_to_counter(axis, q), counts_per_mm), counts_per_mm))
                for axis, q in self._targets(targets_mm).items()}

    def wait_in_position(self, targets_mm: Targets | Iterable[str] | None = None, *,
                         timeout_s: float | None = None,
                         require_homed: bool = True) -> dict[str, AxisStatus]:
        """Poll until every axis is in position (and at its target, if given) and not moving.

        An axis whose servo goes off on the way, or (``require_homed``) that stops being
        homed, raises at once: a drive switched off and on mid-move stands "in position"
        at a counter that restarted, which no arrival may be taken from."""
        targets = self._wait_targets(targets_mm)
        timeout = timeout_s or self.profile.timing.move_timeout_s
        tolerance = self.position_tolerance_mm()
        deadline = time.monotonic() + timeout
        arrived: dict[str, AxisStatus] = {}
        while True:
            for axis in [a for a in targets if a not in arrived]:
                status = self._arrival(axis, targets[axis], tolerance, require_homed)
                if status is not None:
                    arrived[axis] = status
            if len(arrived) == len(targets):
                return {axis: arrived[axis] for axis in targets}
            if time.monotonic() >= deadline:
                raise self._not_in_position(targets, arrived, timeout)
            time.sleep(self.poll_interval_s)

    def _wait_targets(self, targets_mm: Targets | Iterable[str] | None,
                      ) -> dict[str, float | None]:
        """The axes to wait for and each one's target (None: in position anywhere)."""
        if targets_mm is None:
            return dict.fromkeys(self.axes)
        if isinstance(targets_mm, Mapping):
            return dict(self._targets(targets_mm))
        given = list(targets_mm)  # axis names, or a value per axis
        names = [a for a in given if isinstance(a, str)]
        numbers = [float(v) for v in given if isinstance(v, Real)]
        if len(names) == len(given):
            return dict.fromkeys(self.chosen_axes(names))
        if len(numbers) == len(given):
            return dict(self._targets(numbers))
        raise ValueError(f"targets {given}: axis names or a value per axis, not both")

    def _arrival(self, axis: str, target: float | None, tolerance: float,
                 require_homed: bool) -> AxisStatus | None:
        """The axis's status once it is in position at ``target``, else None. An axis on
        its way is polled by its flag words only; one that says it is in position has
        its position read too."""
        values = self._read_values(axis, self._flag_blocks)
        poll = self._make_poll(axis, values)
        if poll.settled and poll.position_mm is None:
            values |= self._read_values(axis, self._position_blocks)
            poll = self._make_poll(axis, values)
        self._check_vouched(axis, poll, require_homed)
        if poll.settled and poll.position_mm is not None and (
                target is None or abs(poll.position_mm - target) <= tolerance):
            return self._as_status(poll)
        return None

    def _check_vouched(self, axis: str, poll: _Poll, require_homed: bool) -> None:
        """Raise if the axis is in alarm, its servo went off or (``require_homed``) it
        is no longer homed: no arrival may be taken from it then."""
        if poll.fault:
            at = "" if poll.position_mm is None else f" at {poll.position_mm:.3f} mm"
            raise self._fault(axis, f"axis {axis} in alarm {poll.alarm_code:#x}{at} while "
                              "waiting for in-position", poll.alarm_code)
        servo_off = not poll.flags["servo_on"]
        if servo_off or (require_homed and not poll.homed):
            lost = "its servo went off" if servo_off else "it is no longer homed"
            raise self._fault(axis, f"axis {axis}: {lost} while waiting for in-position "
                              "(switched off and on, an emergency stop or another master?); "
                              "its position is not vouched for",
                              "servo_off" if servo_off else "not_homed")

    def _not_in_position(self, targets: dict[str, float | None],
                         arrived: dict[str, AxisStatus], timeout: float) -> DeviceTimeout:
        """The timeout naming each axis not arrived: where it is, its target, its flags."""
        pending = [self._status(a) for a in targets if a not in arrived]
        detail = "; ".join(f"{s.axis} at {s.position_mm:.3f} mm (target {targets[s.axis]}), "
                           f"moving={s.moving}, in_position={s.in_position}" for s in pending)
        return DeviceTimeout(f"not in position within {timeout:g} s: {detail}",
                             where=self.where(pending[0].axis))

    def stop(self, axes: Iterable[str] | None = None) -> None:
        """Stop every axis (all are tried even if one fails; the first error is raised after)."""
        errors: list[DriverError] = []
        chosen = self.chosen_axes(axes)
        for axis in chosen:  # a CiA 402 quick stop may end in "switch on disabled"
            self._servo_off_by_client[axis] = True
        command = self.profile.commands["stop"]
        for steps in (command.start, command.finish):
            for axis in chosen:
                try:
                    self._run_steps("stop", steps, axis, self._params({}))
                except DriverError as exc:
                    log.error("stop %s failed: %s", axis, exc)
                    errors.append(exc)
        if errors:
            raise errors[0]
        for axis in chosen:  # stopped in "quick stop active" (605Ah 5-8): still switched on
            if self._poll(axis, self._flag_blocks).flags["servo_on"]:
                self._servo_off_by_client[axis] = False

    def stop_quietly(self, axes: Sequence[str]) -> None:
        """Stop ``axes``, logging (not raising) a failure: another error is the one to report."""
        try:
            self.stop(axes)
        except DriverError as exc:  # the original failure is the one to report
            log.error("stopping %s after a failed move: %s", ", ".join(axes), exc)

    def reset_alarms(self, axes: Iterable[str] | None = None) -> dict[str, int]:
        """Reset the axes that are in alarm; returns the codes that were cleared.

        On a CiA 402 drive the reset leaves the power stage off: call :meth:`enable`."""
        cleared = {a: s.alarm_code for a, s in self.read_status(axes).items() if s.fault}
        if cleared:
            log.info("resetting alarms %s", {a: hex(c) for a, c in cleared.items()})
            self._forget_written(tuple(cleared))
            for axis in cleared:
                self._servo_off_by_client[axis] = True  # a CiA 402 reset leaves it disabled
            self._run("alarm_reset", tuple(cleared))
        return cleared

    # ================================================================ offsets

    @property
    def software_offsets_mm(self) -> dict[str, float]:
        """The software offset table (to be saved with the machine's configuration)."""
        return dict(self._software_offsets)

    def read_offsets(self, axes: Iterable[str] | None = None) -> dict[str, float]:
        """Joint zero offsets o in mm (q = p - o); on CiA 402, those the next homing applies."""
        chosen = self.chosen_axes(axes)
        spec = self.profile.offset
        if spec.kind == "software":
            return {a: self._software_offsets[a] for a in chosen}
        # counter at the home point = sign × home_offset = -o
        return {a: -spec.sign * float(self.read_raw(a, spec.value)) for a in chosen}

    def write_offsets(self, offsets_mm: Mapping[str, float], *,
                      force: bool = False) -> OffsetChange:
        """Set joint zero offsets o (mm). Returns old and new values (as stored).

        Offsets larger than the profile's limit margin are refused unless
        ``force``: the controller's own limits leave that much room only.
        With a home-offset profile, each value is written, read back and
        compared; it takes effect at the next :meth:`home` (nothing moves here).
        Nothing is saved to non-volatile memory: see :meth:`save_to_nvm`."""
        new = self._per_axis(offsets_mm, "offsets")
        margin = self.profile.limits.margin_mm
        too_large = {a: o for a, o in new.items() if abs(o) > margin}
        if too_large and not force:
            raise ValueError(f"offsets {too_large} exceed the {margin:g} mm margin of profile "
                             f"{self.profile.name!r}; pass force=True to write them anyway")
        old = self.read_offsets(new)
        spec = self.profile.offset
        if spec.kind == "software":
            self._software_offsets.update(new)
            log.info("software offsets %s",
                     ", ".join(f"{a}: {old[a]:+.4f} -> {o:+.4f} mm" for a, o in new.items()))
            return OffsetChange(old, new, "now", written_to_device=False)
        if spec.write_when_disabled:
            on = [a for a, s in self.read_status(new).items() if s.servo_on]
            if on:
                raise self._fault(on[0], f"offsets not written: servo on for {on}; disable "
                                  "first", "servo_on")
        tolerance = 1.0 / self.profile.codec.counts_per_mm
        stored: dict[str, float] = {}
        for axis, offset in new.items():
            register_mm = -spec.sign * offset
            log.info("%s: home offset %s: %+.4f -> %+.4f mm (object %+.4f mm)",
                     self.where(axis), axis, old[axis], offset, register_mm)
            self._write_value(axis, spec.value, register_mm, what=f"write_offsets {axis}")
            back = float(self.read_raw(axis, spec.value))
            if abs(back - register_mm) > tolerance / 2:
                raise self._fault(axis, f"home offset {axis}: wrote {register_mm:+.4f} mm, "
                                  f"read back {back:+.4f} mm", "readback")
            stored[axis] = -spec.sign * back  # what the drive holds, in counts
            self.rehome_required.add(axis)
        return OffsetChange(old, stored, "at_next_homing", written_to_device=True)

    def save_to_nvm(self, axes: Iterable[str] | None = None) -> None:
        """Store the drive parameters in non-volatile memory (explicit request only)."""
        spec = self.profile.nvm
        if spec.kind == "none":
            raise DriverError(f"profile {self.profile.name!r} has nothing to save to "
                              "non-volatile memory (offsets are kept in the tool's "
                              "configuration)")
        for axis in self.chosen_axes(axes):
            log.warning("%s: saving parameters to non-volatile memory (limited write "
                        "endurance)", self.where(axis))
            self._write_value(axis, spec.value, spec.signature, what=f"save_to_nvm {axis}")

    # ================================================================ for the pre-flight check

    def read_temperatures(self) -> dict[str, float]:
        """The temperatures the profile's ``[temperature]`` registers hold, degC
        (``{"ambient": 20.4, "machine": 21.0}``, those it names); empty when the
        profile has none."""
        spec = self.profile.temperature
        if spec is None:
            return {}
        out = {}
        for key in ("ambient", "machine"):
            name = getattr(spec, key)
            if name:
                out[key] = int(self.read_raw(spec.axis, name)) * spec.degc_per_count
        return out

    @property
    def reports_reference(self) -> bool:
        """Whether the drive itself says it is homed (a ``homed`` flag in the profile:
        IAI's HEND); else only this client's memory of a homing, lost with the link."""
        return "homed" in self.profile.flags

    def forget_reference(self, axes: Iterable[str] | None = None) -> None:
        """This client no longer vouches for the axes' homing: no move until :meth:`home`
        (where the drive reports its own homing, the drive's word still decides)."""
        for axis in self.chosen_axes(axes):
            self._homed_latch[axis] = False

    def _latched_homed(self, axis: str) -> bool:
        """Homed by this client's memory, and the drive never out of reach since."""
        if self._links[axis].stats.losses != self._losses_at_home[axis]:
            self._homed_latch[axis] = False
        return self._homed_latch[axis]

    # ================================================================ internals: coordinates

    def chosen_axes(self, axes: Iterable[str] | None = None) -> tuple[str, ...]:
        """``axes`` checked against this controller's (all of them for None)."""
        if axes is None:
            return self.axes
        chosen = tuple(axes)
        unknown = [a for a in chosen if a not in self.axes]
        if unknown:
            raise ValueError(f"unknown axes {unknown}; this controller drives {list(self.axes)}")
        return chosen

    def _per_axis(self, values: Mapping[str, float], what: str) -> dict[str, float]:
        out = {}
        for axis, value in values.items():
            self.chosen_axes([axis])
            if not math.isfinite(value):
                raise ValueError(f"{what}: {axis} = {value} is not a finite number")
            out[axis] = float(value)
        return out

    def _targets(self, targets_mm: Targets) -> dict[str, float]:
        if isinstance(targets_mm, Mapping):
            return self._per_axis(targets_mm, "move targets")
        values = list(targets_mm)
        if len(values) != len(self.axes):
            raise ValueError(f"move targets: {len(values)} values for axes {list(self.axes)}")
        return self._per_axis(dict(zip(self.axes, values, strict=True)), "move targets")

    def _q_to_counter(self, axis: str, q: float) -> float:
        return q + self._software_offsets[axis]

    def _counter_to_q(self, axis: str, counter: float) -> float:
        return counter - self._software_offsets[axis]

    def counter_at_home_mm(self, axis: str) -> float:
        """Where the position counter will read at the home point after this homing."""
        spec = self.profile.offset
        if spec.kind == "software":
            return 0.0
        return spec.sign * float(self.read_raw(axis, spec.value))

    def position_tolerance_mm(self) -> float:
        """How far from a target an axis may read and be at it: a count, or the
        in-position band."""
        one_count = 1.0 / self.profile.codec.counts_per_mm
        return max(self.profile.motion.in_position_band_mm, one_count) + 1e-9

    def where(self, axis: str) -> str:
        """Endpoint, device id and axis, for messages."""
        return f"{self._links[axis].where(self.device_ids[axis])} (axis {axis})"

    def _fault(self, axis: str, message: str, code: int | str) -> DeviceFault:
        return DeviceFault(message, code=code, where=self.where(axis))

    # ================================================================ internals: registers

    def _plan_reads(self, names: Iterable[str]) -> list[_Block]:
        """Contiguous read requests covering ``names`` (gaps up to the profile's limit),
        none longer than the 125 registers one FC 3 request may ask for (Modbus
        Application Protocol V1.1b3 §6.3: quantity 1 to 125, else exception 3)."""
        specs = sorted((self.profile.value(n) for n in names), key=lambda s: s.address)
        blocks: list[_Block] = []
        gap = self.profile.status.max_gap_registers
        for spec in specs:
            end = spec.address + spec.words
            if blocks and spec.address - (blocks[-1].address + blocks[-1].count) <= gap \
                    and max(end, blocks[-1].address + blocks[-1].count) - blocks[-1].address \
                    <= MAX_READ_REGISTERS:
                last = blocks[-1]
                end = max(last.address + last.count, end)
                blocks[-1] = _Block(last.address, end - last.address, (*last.names, spec.name))
            else:
                blocks.append(_Block(spec.address, spec.words, (spec.name,)))
        return blocks

    def _status(self, axis: str) -> AxisStatus:
        return self._as_status(self._poll(axis, self._blocks))

    def _poll(self, axis: str, blocks: Sequence[_Block]) -> _Poll:
        return self._make_poll(axis, self._read_values(axis, blocks))

    def _read_values(self, axis: str, blocks: Sequence[_Block]) -> dict[str, float | int]:
        device, link = self.device_ids[axis], self._links[axis]
        values: dict[str, float | int] = {}
        for block in blocks:
            registers = link.read_registers(device, block.address, block.count)
            for name in block.names:
                spec = self.profile.value(name)
                offset = spec.address - block.address
                values[name] = self.profile.decode(name, registers[offset : offset + spec.words])
        return values

    def _make_poll(self, axis: str, values: Mapping[str, float | int]) -> _Poll:
        flags = {name: self.profile.flag_state(name, int(values[f.value]))
                 for name, f in self.profile.flags.items()}
        fault = any(flags[f] for f in self.profile.status.fault_flags)
        if fault:
            self._forget_written([axis])
        if "homed" not in flags and not flags["servo_on"] and not fault \
                and self._homed_latch[axis] and not self._servo_off_by_client[axis]:
            # Switched off, not by this client and not by a fault it sees: a power cycle
            # (the drive starts in "switch on disabled" and its incremental encoder counts
            # from wherever the axis stands) or another master. The drive cannot say
            # whether it kept its reference, so this client no longer vouches for it.
            # (A fault is the caller's to judge: the campaign re-homes after an alarm.)
            log.warning("%s: servo found off without a disable from this client; the "
                        "homing no longer counts", self.where(axis))
            self._homed_latch[axis] = False
        alarm_name = self.profile.status.alarm_code
        if alarm_name in values:
            alarm_code = int(values[alarm_name])
        else:
            alarm_code = int(self.read_raw(axis, alarm_name)) if fault else 0
        position = values.get(self.profile.status.position)
        return _Poll(axis, flags, fault, alarm_code,
                     homed=flags["homed"] if "homed" in flags else self._latched_homed(axis),
                     position_mm=None if position is None
                     else self._counter_to_q(axis, float(position)))

    def _as_status(self, poll: _Poll) -> AxisStatus:
        assert poll.position_mm is not None, "a status needs the position read"
        self._last_seen_q[poll.axis] = poll.position_mm
        return AxisStatus(axis=poll.axis, position_mm=poll.position_mm,
                          in_position=poll.flags["in_position"], moving=poll.flags["moving"],
                          servo_on=poll.flags["servo_on"], homed=poll.homed,
                          alarm_code=poll.alarm_code, fault=poll.fault, flags=poll.flags)

    def counter_mm(self, status: AxisStatus) -> float:
        """The controller's own position counter behind a status (software offset added)."""
        return status.position_mm + self._software_offsets[status.axis]

    def read_raw(self, axis: str, name: str) -> float | int | bool:
        """One named value of the profile, decoded (for checks outside the status poll)."""
        spec = self.profile.value(name)
        device, link = self.device_ids[axis], self._links[axis]
        if spec.function == "coil":
            return link.read_coils(device, spec.address, 1)[0]
        registers = link.read_registers(device, spec.address, spec.words)
        return self.profile.decode(name, registers)

    def _write_value(self, axis: str, name: str, value: Any, *, what: str) -> None:
        self._write(axis, (name,), (value,), what=what)

    def _write(self, axis: str, names: Sequence[str], values: Sequence[Any], *,
               what: str, block: bool = False) -> None:
        """Write contiguous values in one request: a coil by FC 5, one register by FC 6
        where the drive has it, else (and a ``block`` always) FC 16 (also one register
        on a drive without FC 6, MR-JE-C)."""
        specs: list[ValueSpec] = [self.profile.value(n) for n in names]
        device, link, address = self.device_ids[axis], self._links[axis], specs[0].address
        encoded = [self.profile.encode(n, v) for n, v in zip(names, values, strict=True)]
        label = f"{what}: " + ", ".join(f"{n}={v}" for n, v in zip(names, values, strict=True))
        for name in names:
            self._written.pop((axis, name), None)  # unknown until the write succeeds
        if specs[0].function == "coil" and not block:
            link.write_coil(device, address, bool(encoded[0]), what=label)
            self._remember_written(axis, names[0], encoded[0])
            return
        registers: list[int] = []
        for words in encoded:
            assert isinstance(words, list)  # registers, not a coil: a block is registers
            registers += words
        if len(registers) == 1 and self.profile.transport.single_register_write and not block:
            link.write_register(device, address, registers[0], what=label)
        else:
            link.write_registers(device, address, registers, what=label)
        for name, words in zip(names, encoded, strict=True):
            self._remember_written(axis, name, words)

    # ================================================================ internals: written values

    def _remember_written(self, axis: str, name: str, encoded: Any) -> None:
        self._drop_written_after_failures()
        self._written[(axis, name)] = tuple(encoded) if isinstance(encoded, list) else (encoded,)

    def _unchanged(self, axis: str, name: str, value: Any) -> bool:
        """Whether this client's last write of ``name`` on ``axis`` was ``value``."""
        self._drop_written_after_failures()
        encoded = self.profile.encode(name, value)
        key = tuple(encoded) if isinstance(encoded, list) else (encoded,)
        return self._written.get((axis, name)) == key

    def _drop_written_after_failures(self) -> None:
        # After a failed transaction (a write that may or may not have landed, a
        # lost link, a drive that rebooted), what the device holds is unknown.
        failures = sum(link.stats.failures for link in self.links)
        if failures != self._written_failures:
            self._written.clear()
            self._written_failures = failures

    def _forget_written(self, axes: Iterable[str]) -> None:
        gone = set(axes)
        for key in [k for k in self._written if k[0] in gone]:
            del self._written[key]

    # ================================================================ internals: sequences

    def _params(self, given: Mapping[str, Any]) -> dict[str, Any]:
        """The step parameters: the profile's and this client's, overridden by ``given``."""
        params: dict[str, Any] = {"band_mm": self.profile.motion.in_position_band_mm,
                                  "speed_mm_s": self.speed_mm_s,
                                  **asdict(self.profile.timing)}  # the timeouts
        params.update({k: v for k, v in given.items() if v is not None})
        return params

    def _run(self, command: str, axes: Sequence[str], common: Mapping[str, Any] | None = None,
             per_axis: Mapping[str, Mapping[str, Any]] | None = None) -> None:
        """Run a profile command: start steps axis after axis, then finish steps."""
        params = {axis: self._params({**(common or {}), **(per_axis or {}).get(axis, {})})
                  for axis in axes}
        spec = self.profile.commands[command]
        for axis in axes:
            self._run_steps(command, spec.start, axis, params[axis])
        for axis in axes:
            self._run_steps(command, spec.finish, axis, params[axis])

    def _resolve(self, value: Any, params: Mapping[str, Any], command: str) -> Any:
        if isinstance(value, str) and value.startswith("$"):
            try:
                return params[value[1:]]
            except KeyError:
                raise ValueError(f"command {command!r} needs {value} and none was given") from None
        return value

    def _run_steps(self, command: str, steps: Sequence[CommandStep], axis: str,
                   params: Mapping[str, Any]) -> None:
        what = f"{command} {axis}"
        for step in steps:
            timeout = float(self._resolve(step.timeout_s, params, command))  # a wait's bound
            if step.op in ("write", "write_block"):
                values = [self._resolve(v, params, command) for v in step.value]
                if step.skip_unchanged and self._unchanged(axis, step.to[0], values[0]):
                    continue
                self._write(axis, step.to, values, block=step.op == "write_block",
                            what=what + (" (edge, sent once)" if step.edge else ""))
            elif step.op == "wait" and step.until:
                self._wait_any(axis, command, step.until, timeout)
            elif step.op == "wait":
                self._wait_flag(axis, command, step.flag, step.state, timeout)
            elif step.op == "cia402_enable":
                self._enable_cia402(axis, command, step, timeout)
            else:
                self._confirm(axis, command, step, params)

    def _wait_flag(self, axis: str, command: str, flag: str, state: bool,
                   timeout_s: float) -> _Poll:
        return self._wait_any(axis, command, (((flag, state),),), timeout_s,
                              waiting=f" for {flag}={state}", late=f"{flag} did not become {state}")

    def _enable_cia402(self, axis: str, command: str, step: CommandStep, timeout_s: float) -> None:
        """Walk the CiA 402 state machine to "operation enabled" from the state the drive
        reports, one transition at a time, each awaited (``timeout_s``) before the next:
        a drive already enabled is sent nothing (never shutdown, transition 8)."""
        word = int(self.read_raw(axis, step.status))
        for _ in range(MOST_TRANSITIONS + 2):  # + quick stop active and not ready
            state = drive_state(word)
            if state is DriveState.OPERATION_ENABLED:
                return
            if state in (DriveState.FAULT, DriveState.FAULT_REACTION_ACTIVE, None):
                what = f"statusword {word:#06x}, no CiA 402 state" if state is None \
                    else state.value
                raise self._fault(axis, f"{command} {axis}: the drive reports {what}; reset "
                                  "its alarm first", "fault")
            assert state is not None
            if state is DriveState.NOT_READY_TO_SWITCH_ON or (
                    state is DriveState.QUICK_STOP_ACTIVE and not word & TARGET_REACHED):
                # transition 1 is the drive's own; 16 is taken once the drive stands
                done = _left(state) if state is DriveState.NOT_READY_TO_SWITCH_ON \
                    else _left_or_standing(state)
                word = self._await_statusword(axis, command, step, done,
                                              f"leaving {state.value}", timeout_s)
                continue
            control, transition = TOWARDS_OPERATION[state]
            self._write_value(axis, step.to[0], control,
                              what=f"{command} {axis} (transition {transition})")
            word = self._await_statusword(axis, command, step, _left(state),
                                          f"leaving {state.value}", timeout_s)
        raise self._fault(axis, f"{command} {axis}: statusword {word:#06x} after every "
                          "transition to operation enabled", "servo_off")

    def _await_statusword(self, axis: str, command: str, step: CommandStep,
                          done: Callable[[int], bool], awaited: str, timeout_s: float) -> int:
        """Poll the statusword until ``done`` holds for it; the word."""
        deadline = time.monotonic() + timeout_s
        while True:
            word = int(self.read_raw(axis, step.status))
            if done(word):
                return word
            if time.monotonic() >= deadline:
                raise DeviceTimeout(f"{command} {axis}: {awaited} not seen within "
                                    f"{timeout_s:g} s (statusword {word:#06x})",
                                    where=self.where(axis))
            time.sleep(self.poll_interval_s)

    def _refuse_mirrored_home(self, axis: str, command: str, seen: float, at: float) -> None:
        """Done at the opposite of the home value the profile predicts: the drive applies
        its home offset with the other sign. A drive that homes at once (CiA 402
        methods 35, 37) shows it before any motion; said now, not as a timeout."""
        offset = self.profile.offset
        field = "offset.sign" if offset.kind == "home_offset" else "codec.word_order"
        fix = (f"change offset.sign to {-offset.sign:+d}" if offset.kind == "home_offset"
               else "check codec.word_order")
        raise PreflightError(
            f"{command} {axis}: the drive reports done at {seen:+.4f} mm, the opposite of "
            f"the {at:+.4f} mm the profile predicts: {fix} in profile "
            f"{self.profile.name!r}", field=field, where=self.where(axis))

    def _wait_any(self, axis: str, command: str, until: Sequence[Sequence[tuple[str, bool]]],
                  timeout_s: float, *, waiting: str = "", late: str = "") -> _Poll:
        """Poll until the flags match one of the ``until`` alternatives (all of its
        flag states at once); an alarm ends the wait unless an alternative asks for it.
        ``waiting``, ``late``: the words of a wait on one flag."""
        deadline = time.monotonic() + timeout_s
        tolerate_fault = any(flag in self.profile.status.fault_flags
                             for alternative in until for flag, _ in alternative)
        while True:
            status = self._poll(axis, self._flag_blocks)
            if any(all(status.flags[flag] == state for flag, state in alternative)
                   for alternative in until):
                return status
            if status.fault and not tolerate_fault:
                raise self._fault(axis, f"{command} {axis}: alarm {status.alarm_code:#x} while "
                                  f"waiting{waiting}", status.alarm_code)
            if time.monotonic() >= deadline:
                missed, seen = (late, "") if late else _unmet(until, status.flags)
                raise DeviceTimeout(f"{command} {axis}: {missed} within {timeout_s:g} s{seen}",
                                    where=self.where(axis))
            time.sleep(self.poll_interval_s)

    def _confirm(self, axis: str, command: str, step: CommandStep,
                 params: Mapping[str, Any]) -> AxisStatus:
        """Read back that an edge-triggered write was taken; never re-send it."""
        timeout_s = float(self._resolve(step.timeout_s, params, command))
        at = float(self._resolve(step.at, params, command))
        tolerance = self.position_tolerance_mm()
        deadline = time.monotonic() + timeout_s
        while True:
            status = self._status(axis)
            if status.fault:
                raise self._fault(axis, f"{command} {axis}: refused with alarm "
                                  f"{status.alarm_code:#x}", status.alarm_code)
            if any(status.flags[f] for f in step.any):
                return status
            seen = self.counter_mm(status)
            if status.flags[step.done] and abs(seen - at) <= tolerance:
                return status  # finished before the first poll
            if status.flags[step.done] and abs(at) > tolerance and abs(seen + at) <= tolerance:
                self._refuse_mirrored_home(axis, command, seen, at)
            if time.monotonic() >= deadline:
                raise DeviceTimeout(f"{command} {axis}: not acknowledged within {timeout_s:g} s "
                                    f"(none of {', '.join(step.any)} set, not at {at:.3f} mm); "
                                    "the command was not re-sent", where=self.where(axis))
            time.sleep(self.poll_interval_s)


def _unmet(until: Sequence[Sequence[tuple[str, bool]]],
           flags: Mapping[str, bool]) -> tuple[str, str]:
    """The words of a wait for any of ``until`` that timed out: what was awaited, and
    the flags last seen."""
    wanted = " or ".join("(" + ", ".join(f"{f}={v}" for f, v in alternative) + ")"
                         for alternative in until)
    seen = ", ".join(f"{f}={flags[f]}" for f in dict.fromkeys(
        f for alternative in until for f, _ in alternative))
    return f"none of {wanted}", f" (last seen {seen})"


def _left(state: DriveState) -> Callable[[int], bool]:
    """Whether a statusword codes another state than ``state``."""
    return lambda word: drive_state(word) is not state


def _left_or_standing(state: DriveState) -> Callable[[int], bool]:
    """Left ``state``, or standing (target reached) in it: a drive in quick stop active
    takes enable operation (transition 16) once it stands."""
    return lambda word: drive_state(word) is not state or bool(word & TARGET_REACHED)
