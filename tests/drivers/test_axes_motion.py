"""Motion model of the simulated axes, on a clock the tests move by hand."""

from __future__ import annotations

import threading
import time

import pytest

from ogacq_drivers.sim.clock import SimClock
from ogacq_drivers.sim.motion import Alarm, MotionModel, Outcome


class FrozenClock(SimClock):
    """A SimClock that only moves when told (so tests do not depend on real time)."""

    def __init__(self) -> None:
        super().__init__(speed=1.0)
        self.t = 0.0

    def now(self) -> float:
        return self.t

    def advance(self, seconds: float) -> None:
        self.t += seconds


@pytest.fixture
def clock() -> FrozenClock:
    return FrozenClock()


@pytest.fixture
def model(clock: FrozenClock) -> MotionModel:
    m = MotionModel(clock, speed_mm_s=100.0, accel_mm_s2=1000.0, settle_s=0.05, home_search_s=0.5)
    for axis in m.axes:
        m.set_servo(axis, True)
    return m


def test_move_takes_time_then_settles(model: MotionModel, clock: FrozenClock) -> None:
    assert model.move_to("x", 60.0) is Outcome.STARTED
    # 0.1 s ramps of 5 mm each, 50 mm at 100 mm/s: 0.7 s in all
    clock.advance(0.05)
    early = model.snapshot("x")
    assert early.moving and not early.in_position
    assert early.raw_mm == pytest.approx(0.5 * 1000.0 * 0.05**2)
    clock.advance(0.4)  # t = 0.45: constant speed phase
    assert model.raw_position_mm("x") == pytest.approx(5.0 + 100.0 * 0.35)
    clock.advance(0.26)  # t = 0.71: arrived, settling
    snap = model.snapshot("x")
    assert not snap.moving and not snap.in_position and snap.raw_mm == 60.0
    clock.advance(0.05)
    assert model.snapshot("x").in_position
    assert model.last_direction("x") == 1


def test_short_move_is_triangular_and_direction_is_kept(
    model: MotionModel, clock: FrozenClock
) -> None:
    assert model.last_direction("y") == 0
    model.move_to("y", -1.0)
    clock.advance(2 * (1.0 / 1000.0) ** 0.5 + 1e-9)
    assert model.raw_position_mm("y") == -1.0
    assert model.last_direction("y") == -1
    model.move_to("y", -1.0)  # no motion: direction unchanged
    assert model.last_direction("y") == -1


def test_soft_limit_alarm_without_motion(model: MotionModel, clock: FrozenClock) -> None:
    assert model.hard_limits_mm == (-102.0, 62.0)
    assert model.move_to("z", 62.5) is Outcome.SOFT_LIMIT
    clock.advance(1.0)
    snap = model.snapshot("z")
    assert snap.alarm is Alarm.SOFT_LIMIT and snap.raw_mm == 0.0 and not snap.moving
    assert model.move_to("z", 10.0) is Outcome.IN_ALARM
    model.reset_alarm("z")
    assert model.move_to("z", 61.5) is Outcome.STARTED


def test_servo_off_means_no_motion(model: MotionModel, clock: FrozenClock) -> None:
    model.move_to("x", 50.0)
    clock.advance(0.2)
    model.set_servo("x", False)
    where = model.raw_position_mm("x")
    clock.advance(2.0)
    assert model.raw_position_mm("x") == where
    assert model.move_to("x", 10.0) is Outcome.SERVO_OFF
    assert model.home("x") is Outcome.SERVO_OFF


def test_homing_ends_at_raw_zero_with_counter_redefined(clock: FrozenClock) -> None:
    model = MotionModel(clock, initial_raw_mm={"x": 12.0}, home_search_s=0.5)
    model.set_servo("x", True)
    assert model.snapshot("x").counter_mm == 0.0  # incremental counter starts at 0
    assert not model.snapshot("x").homed
    assert model.home("x", home_position_mm=-0.5) is Outcome.STARTED
    clock.advance(0.1)
    assert model.snapshot("x").homing
    clock.advance(5.0)
    snap = model.snapshot("x")
    assert snap.homed and not snap.homing and snap.raw_mm == 0.0
    assert snap.counter_mm == -0.5
    assert model.last_direction("x") == -1
    model.move_to("x", 10.0)  # counter 10 -> raw 10.5
    clock.advance(5.0)
    assert model.raw_position_mm("x") == pytest.approx(10.5)


def test_stop_freezes_and_cancels(model: MotionModel, clock: FrozenClock) -> None:
    model.move_to("x", 60.0)
    clock.advance(0.3)
    model.stop("x")
    where = model.raw_position_mm("x")
    assert 0.0 < where < 60.0
    clock.advance(2.0)
    snap = model.snapshot("x")
    assert snap.raw_mm == where and not snap.moving and snap.in_position


def test_bad_configuration_is_refused(clock: FrozenClock) -> None:
    with pytest.raises(ValueError, match="soft limits"):
        MotionModel(clock, soft_min_mm=10.0, soft_max_mm=0.0)
    with pytest.raises(ValueError, match="speed_mm_s"):
        MotionModel(clock, speed_mm_s=0.0)
    with pytest.raises(KeyError, match="no axis 'w'"):
        MotionModel(clock).raw_position_mm("w")


def test_thread_safe_under_concurrent_calls() -> None:
    model = MotionModel(SimClock(speed=1000.0))
    for axis in model.axes:
        model.set_servo(axis, True)
    errors: list[BaseException] = []

    def hammer(axis: str) -> None:
        try:
            for i in range(300):
                model.move_to(axis, float(i % 50))
                model.snapshot(axis)
                model.raw_position_mm(axis)
                if i % 7 == 0:
                    model.stop(axis)
        except BaseException as exc:  # noqa: BLE001 - collected for the assertion below
            errors.append(exc)

    threads = [threading.Thread(target=hammer, args=(a,)) for a in model.axes for _ in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors


def test_a_held_clock_stands_still_until_released_and_runs_on_from_there() -> None:
    running = SimClock(speed=50.0)
    running.hold()
    held = running.now()
    time.sleep(0.02)  # 1 s of simulated time, had it run
    assert running.now() == held
    running.advance(2.0)
    assert running.now() == held + 2.0
    running.release()
    assert held + 2.0 <= running.now() < held + 2.0 + 50.0 * 60  # on, from there
