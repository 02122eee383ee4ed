"""Stops as CiA 402 defines them, against the independent emulator (modbus_tk,
tests/emulators/drives.py): the quick stop option code 605Ah decides how the drive
slows down and where it ends, "switch on disabled" (codes 0-4) or "quick stop
active" (5-8, at rest a stop too: statusword bit 2 stays set); the client's stop
accepts every one, the enable walks the state machine back (transition 16 out of
quick stop active), and nothing resumes the aborted move."""

from __future__ import annotations

import time

import pytest

from tests.drivers.test_axes_independent_server import bench
from tests.emulators.drives import Cia402Drive

pytestmark = pytest.mark.filterwarnings("ignore:isSet:DeprecationWarning")

SLOW_DOWN = 2_000.0  # counts/s^2: 1000 counts/s (10 mm/s) stops in 0.5 s, 250 counts on
QUICK = 200_000.0    # counts/s^2: the same stop in 5 ms, 2.5 counts on


@pytest.mark.parametrize("code", range(9))
def test_every_quick_stop_option_code_stops_cleanly(code: int) -> None:
    with bench("cia402", "tcp") as b:
        c, x = b.controller, b.drives["x"]
        assert isinstance(x, Cia402Drive)
        x.quick_stop_option_code, x.slow_down_ramp, x.quick_stop_ramp = code, SLOW_DOWN, QUICK
        c.enable(["x"])
        c.home(["x"])
        c.move_to({"x": -50.0}, speed_mm_s=10.0, wait=False)  # 5 s
        time.sleep(0.3)
        c.stop(["x"])  # no DeviceTimeout, whichever state the code leaves it in
        assert not x.motion.moving
        assert x.state == ("quick_stop_active" if code >= 5 else "switch_on_disabled")
        stopped = x.motion.now()
        assert x.quick_stop_at is not None
        braked = abs(stopped - x.quick_stop_at)
        if code in (1, 5):  # on the slow-down ramp: v^2 / 2a = 250 counts
            assert braked == pytest.approx(250, abs=30)
        elif code in (2, 6):  # on the quick stop ramp
            assert braked < 10
        elif code == 0:  # power stage off at once
            assert braked < 1
        status = c.read_status(["x"])["x"]
        assert not status.moving
        with pytest.raises(Exception, match="enable first"):  # no set-point in a stop
            c.move_to({"x": 0.0})
        c.enable(["x"])  # 0x06, 0x07 have no transition from quick stop active; 0x0F is 16
        assert x.state == "operation_enabled"
        time.sleep(0.3)
        assert x.motion.now() == stopped  # the aborted move stays aborted
        assert c.move_to({"x": -1.0}, speed_mm_s=50.0)["x"].position_mm == pytest.approx(
            -1.0, abs=0.011)


@pytest.mark.parametrize("code", [2, 6])
def test_disable_leaves_every_state_by_disable_voltage(code: int) -> None:
    with bench("cia402", "tcp") as b:
        c, x = b.controller, b.drives["x"]
        assert isinstance(x, Cia402Drive)
        x.quick_stop_option_code = code
        c.enable(["x"])
        c.stop(["x"])
        c.disable(["x"])  # shutdown (0x06) would leave quick stop active as it is
        assert x.state == "switch_on_disabled"
        assert not c.read_status(["x"])["x"].servo_on
