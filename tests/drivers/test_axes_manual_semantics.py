"""The simulated controllers behave as the makers' manuals say, where that is dangerous.

IAI [ME0162]: releasing the pause STP resumes the remaining distance; the alarm
reset happens on ALRS's change back to 0000. CiA 402: releasing halt in profile
position mode continues the positioning. These tests drive the simulator by
raw Modbus writes (pymodbus client over TCP), and show that the stop and reset
sequences this tool shipped before issue 11 fail against it: the simulator now
catches the defects a real drive would have shown.
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import pytest

from ogacq_drivers.axes.controller import AxisController
from ogacq_drivers.axes.profile import Profile, load_profile
from ogacq_drivers.errors import DeviceTimeout
from ogacq_drivers.sim.motion import Alarm
from tests.drivers.drive_rig import simulated_drive


def _homed_and_moving(c: AxisController) -> None:
    c.enable(["x"])
    c.home(["x"])
    c.move_to({"x": -90.0}, speed_mm_s=5.0, wait=False)  # 18 s simulated


def test_iai_stp_release_resumes_the_move_and_the_decel_stop_cancels_it() -> None:
    profile = load_profile("iai-pcon")
    stp = profile.value("pause_command").address
    stop = profile.value("decel_stop_command").address
    with simulated_drive(profile) as (c, model, _server, link):
        _homed_and_moving(c)
        link.write_coil(1, stp, True, what="test: STP on")
        held = model.raw_position_mm("x")
        assert -90.0 < held < 0.0 and model.has_paused_move("x")
        link.write_coil(1, stp, False, what="test: STP off")
        assert c.wait_in_position({"x": -90.0}, timeout_s=5.0)["x"].position_mm == (
            pytest.approx(-90.0, abs=0.011))  # the paused move went on to its end
        c.move_to({"x": 0.0}, speed_mm_s=5.0, wait=False)
        link.write_coil(1, stp, True, what="test: STP on")
        link.write_coil(1, stop, True, what="test: STOP")
        assert link.read_coils(1, stop, 1) == [False]  # the deceleration stop resets itself
        link.write_coil(1, stp, False, what="test: STP off")
        time.sleep(0.1)
        assert not model.snapshot("x").moving  # the paused move was cancelled


def test_iai_alarm_reset_acts_on_the_change_back_to_0000() -> None:
    profile = load_profile("iai-pcon")
    alrs = profile.value("alarm_reset_command").address
    with simulated_drive(profile) as (c, model, _server, link):
        c.enable(["x"])
        model.inject_alarm("x", Alarm.OVERLOAD)
        link.write_coil(1, alrs, True, what="test: ALRS FF00")
        assert c.read_status(["x"])["x"].fault  # not yet: FF00 alone resets nothing
        link.write_coil(1, alrs, False, what="test: ALRS 0000")
        assert not c.read_status(["x"])["x"].fault
        model.inject_alarm("x", Alarm.OVERLOAD)
        assert c.reset_alarms(["x"]) == {"x": profile.sim.soft_limit_alarm_code}
        assert not c.read_status(["x"])["x"].fault


def test_cia402_halt_release_continues_the_positioning() -> None:
    profile = load_profile("cia402")
    controlword = profile.value("controlword").address
    with simulated_drive(profile) as (c, model, _server, link):
        _homed_and_moving(c)
        link.write_register(1, controlword, 0x010F, what="test: halt")
        assert model.has_paused_move("x")
        link.write_register(1, controlword, 0x000F, what="test: halt released")
        assert c.wait_in_position({"x": -90.0}, timeout_s=5.0)["x"].position_mm == (
            pytest.approx(-90.0, abs=0.011))


def _old(profile_name: str, tmp_path: Path, sections: dict[str, str]) -> Profile:
    """The shipped profile with whole [commands.*] sections replaced."""
    text = Path(load_profile(profile_name).source).read_text(encoding="utf-8")
    for header, body in sections.items():
        start = text.index(header)
        end = text.find("\n[", start + 1)
        text = text[:start] + body + (text[end:] if end >= 0 else "")
    path = tmp_path / f"{profile_name}-before-issue-11.toml"
    path.write_text(text, encoding="utf-8")
    return load_profile(path)


def test_the_stop_and_reset_shipped_before_are_caught(tmp_path: Path) -> None:
    """The sequences of the profile before issue 11 fail against this simulator."""
    stp_stop = _old("iai-pcon", tmp_path, {"[commands.stop]": """[commands.stop]
start = [{ op = "write", to = "pause_command", value = true }]
finish = [{ op = "wait", flag = "moving", state = false }]
""", "[commands.enable]": """[commands.enable]
start = [
  { op = "write", to = "modbus_control", value = true },
  { op = "write", to = "pause_command", value = false },
  { op = "write", to = "servo_on_command", value = true },
]
finish = [{ op = "wait", flag = "servo_on", state = true, timeout_s = "$enable_timeout_s" }]
"""})
    with simulated_drive(stp_stop) as (c, model, _server, link):
        _homed_and_moving(c)
        c.stop(["x"])
        stopped = model.raw_position_mm("x")
        c.reset_alarms(["x"])
        c.enable(["x"])  # releases STP: the aborted move completes
        time.sleep(0.1)
        assert model.raw_position_mm("x") < stopped - 1.0

    wait_between = _old("iai-pcon", tmp_path, {"[commands.alarm_reset]": """[commands.alarm_reset]
start = [
  { op = "write", to = "alarm_reset_command", value = false },
  { op = "write", to = "alarm_reset_command", value = true, edge = true },
  { op = "wait", flag = "alarm", state = false },
  { op = "write", to = "alarm_reset_command", value = false },
]
"""})
    quick = dataclasses.replace(
        wait_between, timing=dataclasses.replace(wait_between.timing, ack_timeout_s=0.3))
    with simulated_drive(quick) as (c, model, _server, _link):
        c.enable(["x"])
        model.inject_alarm("x", Alarm.OVERLOAD)
        with pytest.raises(DeviceTimeout, match="alarm did not become False"):
            c.reset_alarms(["x"])
