"""Motion of the three simulated linear axes, on the shared :class:`SimClock`.

The model knows nothing about Modbus: the simulated controller
(``modbus_server.py``) turns register writes into calls here and reads the
state back on every request; the simulated machine reads the physical joint
positions (:meth:`MotionModel.raw_position_mm`) and the direction of the last
motion (:meth:`MotionModel.last_direction`, for backlash) to compute the gauges.

Two coordinates per axis:

- ``raw``: the physical joint position in mm from the mechanical zero, as the
  machine sees it. Never shifted by any offset.
- ``counter``: what the controller's position counter shows. It starts at 0 at
  power-on (incremental encoder) and is redefined by homing: homing drives the
  axis to raw 0 and sets the counter there to ``home_position_mm`` (0 for a
  controller without home offset; the drive's home offset for CiA 402).
  ``counter = raw - reference``.

Moves follow a trapezoidal speed profile, then settle for ``settle_s`` before
the axis reports in position. Stops are immediate (no deceleration ramp): the
simulator favours clarity over dynamics. Two kinds of stop, as drives have
them: :meth:`MotionModel.stop` cancels the move (IAI deceleration stop, CiA 402
quick stop), :meth:`MotionModel.pause` holds it and :meth:`MotionModel.resume`
goes on for the remaining distance (IAI STP released, CiA 402 halt released),
so a client that releases a pause it used as a stop sees the move complete.
State is computed lazily from the clock on each query, so there is no
background thread; one lock makes every call atomic, because the Modbus
server thread and the machine both call in.
"""

from __future__ import annotations

import enum
import logging
import math
import threading
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from ogacq_drivers.axes.profile import AXIS_NAMES as AXES
from ogacq_drivers.sim.clock import SimClock

log = logging.getLogger(__name__)


class Alarm(enum.Enum):
    """Alarms the model raises; the server maps them to the profile's codes."""

    SOFT_LIMIT = "soft_limit"
    OVERLOAD = "overload"  # injected by tests: a drive fault in the middle of a campaign


class Outcome(enum.Enum):
    """What became of a move or homing command."""

    STARTED = "started"
    SERVO_OFF = "rejected: servo off"
    IN_ALARM = "rejected: alarm active"
    SOFT_LIMIT = "rejected: outside soft limits (alarm raised)"


@dataclass(frozen=True)
class AxisSnapshot:
    """One consistent view of an axis at one instant of simulated time."""

    axis: str
    raw_mm: float
    counter_mm: float
    moving: bool
    in_position: bool
    homing: bool
    homed: bool
    servo_on: bool
    alarm: Alarm | None
    last_direction: int
    target_counter_mm: float


@dataclass
class _Segment:
    """A motion from start_raw to end_raw beginning at start_s."""

    start_s: float
    start_raw: float
    end_raw: float
    speed: float
    accel: float
    dwell_s: float  # extra time at the end still counted as motion (homing search)
    home_position_mm: float | None  # set for a homing: counter value at raw 0

    def __post_init__(self) -> None:
        distance = abs(self.end_raw - self.start_raw)
        t_ramp = self.speed / self.accel
        d_ramp = 0.5 * self.accel * t_ramp**2
        if 2 * d_ramp >= distance:  # triangular profile: never reaches full speed
            self._t_ramp = math.sqrt(distance / self.accel)
            self._t_flat = 0.0
        else:
            self._t_ramp = t_ramp
            self._t_flat = (distance - 2 * d_ramp) / self.speed
        self._v_peak = self.accel * self._t_ramp
        self.travel_s = 2 * self._t_ramp + self._t_flat
        self.end_s = self.start_s + self.travel_s + self.dwell_s

    def raw_at(self, now_s: float) -> float:
        t = min(max(now_s - self.start_s, 0.0), self.travel_s)
        direction = 1.0 if self.end_raw >= self.start_raw else -1.0
        a, tr, tf, vp = self.accel, self._t_ramp, self._t_flat, self._v_peak
        if t <= tr:
            done = 0.5 * a * t * t
        elif t <= tr + tf:
            done = 0.5 * a * tr * tr + vp * (t - tr)
        else:
            td = t - tr - tf
            done = 0.5 * a * tr * tr + vp * tf + vp * td - 0.5 * a * td * td
        return self.end_raw if t >= self.travel_s else self.start_raw + direction * done


@dataclass
class _Axis:
    name: str
    raw_mm: float
    reference_mm: float
    servo_on: bool = False
    homed: bool = False
    alarm: Alarm | None = None
    last_direction: int = 0
    segment: _Segment | None = None
    settled_at_s: float = 0.0
    target_counter_mm: float = 0.0
    #: The move a pause interrupted, resumed when the pause is released.
    paused: _Segment | None = None
    #: When the axis last came to a stop after moving (None: never moved).
    stopped_at_s: float | None = None
    #: Where the axis last reversed (raw mm; None: it has not since power-on).
    reversed_at_raw_mm: float | None = None


class MotionModel:
    """Three simulated axes: moves take time, homing, soft limits, alarms, servo.

    Soft limits apply to the physical (raw) target: a commanded move whose raw
    target is outside ``[soft_min_mm - limit_margin_mm, soft_max_mm + limit_margin_mm]``
    raises :attr:`Alarm.SOFT_LIMIT` and does not move."""

    def __init__(self, clock: SimClock, *, axes: Iterable[str] = AXES, speed_mm_s: float = 100.0,
                 accel_mm_s2: float = 2000.0, settle_s: float = 0.02, home_speed_mm_s: float = 50.0,
                 home_search_s: float = 0.5, soft_min_mm: float = -100.0, soft_max_mm: float = 60.0,
                 limit_margin_mm: float = 2.0,
                 initial_raw_mm: Mapping[str, float] | None = None) -> None:
        for label, value in (("speed_mm_s", speed_mm_s), ("accel_mm_s2", accel_mm_s2),
                             ("home_speed_mm_s", home_speed_mm_s)):
            if not value > 0:
                raise ValueError(f"motion model: {label} must be positive, got {value}")
        if settle_s < 0 or home_search_s < 0 or limit_margin_mm < 0:
            raise ValueError("motion model: settle_s, home_search_s and limit_margin_mm must "
                             "be >= 0")
        if soft_min_mm >= soft_max_mm:
            raise ValueError(f"motion model: soft limits [{soft_min_mm}, {soft_max_mm}] are empty")
        self.clock = clock
        self.speed_mm_s = speed_mm_s
        self.accel_mm_s2 = accel_mm_s2
        self.settle_s = settle_s
        self.home_speed_mm_s = home_speed_mm_s
        self.home_search_s = home_search_s
        self.soft_min_mm = soft_min_mm
        self.soft_max_mm = soft_max_mm
        self.limit_margin_mm = limit_margin_mm
        self._lock = threading.RLock()
        initial = dict(initial_raw_mm or {})
        names = tuple(axes)
        unknown = set(initial) - set(names)
        if unknown:
            raise ValueError(f"motion model: initial position for unknown axes {sorted(unknown)}")
        # the counter of an incremental encoder reads 0 at power-on, wherever the axis is
        self._axes = {n: _Axis(n, raw_mm=float(initial.get(n, 0.0)),
                               reference_mm=float(initial.get(n, 0.0))) for n in names}

    @property
    def axes(self) -> tuple[str, ...]:
        return tuple(self._axes)

    @property
    def hard_limits_mm(self) -> tuple[float, float]:
        """The raw range a move may target: soft limits widened by the margin."""
        return (self.soft_min_mm - self.limit_margin_mm, self.soft_max_mm + self.limit_margin_mm)

    # ---------------------------------------------------------------- queries

    def raw_position_mm(self, axis: str) -> float:
        """Physical joint position in mm from the mechanical zero (no controller offset)."""
        return self.snapshot(axis).raw_mm

    def last_direction(self, axis: str) -> int:
        """+1 / -1: direction of the last motion of ``axis``; 0 before any motion."""
        with self._lock:
            return self._axis(axis).last_direction

    def travel_since_reversal_mm(self, axis: str) -> float:
        """How far ``axis`` has moved since it last reversed (a lost motion that builds up
        with travel depends on it); inf before its first reversal."""
        with self._lock:
            ax, now = self._now(axis)
            if ax.reversed_at_raw_mm is None:
                return math.inf
            raw = ax.raw_mm if ax.segment is None else ax.segment.raw_at(now)
            return abs(raw - ax.reversed_at_raw_mm)

    def stopped_at_s(self) -> float | None:
        """When the last of the axes came to a stop (simulated seconds), None while
        one moves or before any has moved: where the machine's ringing starts."""
        with self._lock:
            now = self.clock.now()
            axes = [self._update(name, now) for name in self._axes]
            if any(ax.segment is not None for ax in axes):
                return None
            stops = [ax.stopped_at_s for ax in axes if ax.stopped_at_s is not None]
            return max(stops) if stops else None

    def snapshot(self, axis: str) -> AxisSnapshot:
        with self._lock:
            ax, now = self._now(axis)
            raw = ax.raw_mm if ax.segment is None else ax.segment.raw_at(now)
            moving = ax.segment is not None
            return AxisSnapshot(
                axis=axis, raw_mm=raw, counter_mm=raw - ax.reference_mm,
                moving=moving, in_position=not moving and now >= ax.settled_at_s,
                homing=ax.segment is not None and ax.segment.home_position_mm is not None,
                homed=ax.homed, servo_on=ax.servo_on, alarm=ax.alarm,
                last_direction=ax.last_direction, target_counter_mm=ax.target_counter_mm)

    # ---------------------------------------------------------------- commands

    def set_servo(self, axis: str, on: bool) -> None:
        """Servo on/off. Off stops any motion where the axis is (and aborts homing)."""
        with self._lock:
            ax, now = self._now(axis)
            if not on and ax.segment is not None:
                self._halt(ax, now)
            if not on:
                ax.paused = None  # simulator's choice: no remaining move survives servo off
            if ax.servo_on != on:
                log.debug("sim axis %s: servo %s", axis, "on" if on else "off")
            ax.servo_on = on

    def move_to(self, axis: str, counter_target_mm: float, *, speed_mm_s: float | None = None,
                accel_mm_s2: float | None = None) -> Outcome:
        """Start an absolute move to a counter position (replaces any move under way)."""
        with self._lock:
            ax, now = self._now(axis)
            refused = self._refusal(ax)
            if refused is not None:
                log.info("sim axis %s: move to %.3f %s", axis, counter_target_mm, refused.value)
                return refused
            raw_target = counter_target_mm + ax.reference_mm
            low, high = self.hard_limits_mm
            if not low <= raw_target <= high:
                self._halt(ax, now)
                ax.alarm = Alarm.SOFT_LIMIT
                log.warning("sim axis %s: target %.3f mm (raw %.3f) outside [%.1f, %.1f]: "
                            "soft-limit alarm", axis, counter_target_mm, raw_target, low, high)
                return Outcome.SOFT_LIMIT
            speed = self._positive(speed_mm_s, self.speed_mm_s)
            accel = self._positive(accel_mm_s2, self.accel_mm_s2)
            ax.paused = None
            self._start(ax, now, raw_target, speed, accel, dwell_s=0.0, home_position_mm=None)
            ax.target_counter_mm = counter_target_mm
            return Outcome.STARTED

    def home(self, axis: str, *, home_position_mm: float = 0.0) -> Outcome:
        """Start homing: go to raw 0, search, then the counter reads ``home_position_mm`` there."""
        with self._lock:
            ax, now = self._now(axis)
            refused = self._refusal(ax)
            if refused is not None:
                log.info("sim axis %s: homing %s", axis, refused.value)
                return refused
            ax.homed = False
            ax.paused = None
            self._start(ax, now, 0.0, self.home_speed_mm_s, self.accel_mm_s2,
                        dwell_s=self.home_search_s, home_position_mm=home_position_mm)
            ax.target_counter_mm = home_position_mm
            return Outcome.STARTED

    def stop(self, axis: str) -> None:
        """Stop where the axis is now and cancel the move (and a paused one); a homing
        stopped half way leaves the axis not homed."""
        with self._lock:
            ax, now = self._now(axis)
            ax.paused = None
            if ax.segment is not None:
                self._halt(ax, now)
                log.info("sim axis %s: stopped at raw %.3f mm", axis, ax.raw_mm)

    def pause(self, axis: str) -> None:
        """Stop where the axis is now but keep the move: :meth:`resume` completes it."""
        with self._lock:
            ax, now = self._now(axis)
            if ax.segment is not None:
                ax.paused = ax.segment
                target = ax.target_counter_mm
                self._halt(ax, now)
                ax.target_counter_mm = target
                log.info("sim axis %s: paused at raw %.3f mm", axis, ax.raw_mm)

    def resume(self, axis: str) -> Outcome | None:
        """Go on for the remaining distance of a paused move (None: nothing was paused)."""
        with self._lock:
            ax, now = self._now(axis)
            seg, ax.paused = ax.paused, None
            if seg is None:
                return None
            refused = self._refusal(ax)
            if refused is not None:
                return refused
            log.info("sim axis %s: pause released, resuming to raw %.3f mm", axis, seg.end_raw)
            self._start(ax, now, seg.end_raw, seg.speed, seg.accel,
                        dwell_s=seg.dwell_s, home_position_mm=seg.home_position_mm)
            return Outcome.STARTED

    def has_paused_move(self, axis: str) -> bool:
        with self._lock:
            return self._axis(axis).paused is not None

    def inject_alarm(self, axis: str, alarm: Alarm = Alarm.OVERLOAD) -> None:
        """A drive fault now: the axis halts where it is and refuses to move until reset."""
        with self._lock:
            ax, now = self._now(axis)
            if ax.segment is not None:
                self._halt(ax, now)
            ax.paused = None
            ax.alarm = alarm
            log.info("sim axis %s: alarm %s injected", axis, alarm.value)

    def reset_alarm(self, axis: str) -> None:
        with self._lock:
            ax = self._axis(axis)
            if ax.alarm is not None:
                log.info("sim axis %s: alarm %s reset", axis, ax.alarm.value)
            ax.alarm = None

    # ---------------------------------------------------------------- internals

    def _axis(self, axis: str) -> _Axis:
        try:
            return self._axes[axis]
        except KeyError:
            raise KeyError(f"motion model has no axis {axis!r} (axes: {', '.join(self._axes)})"
                           ) from None

    @staticmethod
    def _positive(value: float | None, default: float) -> float:
        return default if value is None or not value > 0 else float(value)

    @staticmethod
    def _refusal(ax: _Axis) -> Outcome | None:
        if ax.alarm is not None:
            return Outcome.IN_ALARM
        return Outcome.SERVO_OFF if not ax.servo_on else None

    def _start(self, ax: _Axis, now: float, raw_target: float, speed: float, accel: float, *,
               dwell_s: float, home_position_mm: float | None) -> None:
        raw_now = ax.raw_mm if ax.segment is None else ax.segment.raw_at(now)
        if raw_target != raw_now:
            direction = 1 if raw_target > raw_now else -1
            if ax.last_direction and direction != ax.last_direction:
                ax.reversed_at_raw_mm = raw_now
            ax.last_direction = direction
        ax.raw_mm = raw_now
        ax.segment = _Segment(now, raw_now, raw_target, speed, accel, dwell_s, home_position_mm)
        log.debug("sim axis %s: %s raw %.3f -> %.3f mm over %.3f s", ax.name,
                  "homing" if home_position_mm is not None else "move", raw_now, raw_target,
                  ax.segment.end_s - now)

    def _halt(self, ax: _Axis, now: float) -> None:
        if ax.segment is not None:
            ax.raw_mm = ax.segment.raw_at(now)
            ax.segment = None
            ax.stopped_at_s = now
        ax.target_counter_mm = ax.raw_mm - ax.reference_mm
        ax.settled_at_s = now + self.settle_s

    def _now(self, axis: str) -> tuple[_Axis, float]:
        """The axis as it is now (the caller holds the lock), and now."""
        now = self.clock.now()
        return self._update(axis, now), now

    def _update(self, axis: str, now: float) -> _Axis:
        """Finish a segment whose time is up (lazily, at the next query)."""
        ax = self._axis(axis)
        seg = ax.segment
        if seg is not None and now >= seg.end_s:
            ax.raw_mm = seg.end_raw
            ax.segment = None
            ax.settled_at_s = seg.end_s + self.settle_s
            if seg.end_raw != seg.start_raw:
                ax.stopped_at_s = seg.end_s
            if seg.home_position_mm is not None:
                ax.reference_mm = ax.raw_mm - seg.home_position_mm
                ax.homed = True
                log.info("sim axis %s: homed, counter %.3f mm at raw 0", axis, seg.home_position_mm)
        return ax
