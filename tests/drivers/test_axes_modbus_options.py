"""Per-profile Modbus options a real drive needs: write function codes, unit ids 0..255,
an endpoint per axis. Against the simulator serving only the function codes the
profile lists (it answers anything else "illegal function", as such a drive does)."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from ogacq_drivers.axes.controller import AxisController
from ogacq_drivers.axes.modbus_link import ModbusLink
from ogacq_drivers.axes.profile import Profile, ProfileError, load_profile, parse_profile
from ogacq_drivers.errors import DeviceFault
from ogacq_drivers.sim.clock import SimClock
from ogacq_drivers.sim.modbus_server import ModbusSimServer
from ogacq_drivers.sim.motion import MotionModel


def _variant(name: str, **changes: dict) -> Profile:
    raw = tomllib.loads(Path(load_profile(name).source).read_text(encoding="utf-8"))
    for table, values in changes.items():
        section, _, sub = table.partition("__")
        (raw[section][sub] if sub else raw[section]).update(values)
    return parse_profile(raw, source=f"{name} variant")


FC16_ONLY_255 = {"transport": {"functions": [3, 8, 16]},
                 "axes__device_ids": {"x": 255, "y": 255, "z": 255}}


def test_fc16_only_drive_at_unit_255_one_endpoint_per_axis() -> None:
    profile = _variant("cia402", **FC16_ONLY_255)
    assert not profile.transport.single_register_write
    model = MotionModel(SimClock(speed=50.0))
    servers = [ModbusSimServer(profile, model, transport="tcp", axes=[a]) for a in "xyz"]
    links = {}
    try:
        for axis, server in zip("xyz", servers, strict=True):
            address = server.start()
            links[axis] = ModbusLink(transport="tcp", host=address.host, port=address.port)
        c = AxisController(profile, links)
        c.enable()
        c.home()
        reached = c.move_to({"x": 10.0, "y": -20.0, "z": 5.0})
        assert {a: s.position_mm for a, s in reached.items()} == pytest.approx(
            {"x": 10.0, "y": -20.0, "z": 5.0}, abs=0.011)
        assert "device 255 (axis y)" in c.where("y") and str(servers[1].port) in c.where("y")
        # the same drive written with FC 6 answers "illegal function", as the issue saw
        fc6 = AxisController(_variant("cia402", axes__device_ids={"x": 255, "y": 255,
                                                                   "z": 255}), links)
        with pytest.raises(DeviceFault, match="illegal function"):
            fc6.enable(["x"])
    finally:
        for link in links.values():
            link.close()
        for server in servers:
            server.stop()


def test_unit_ids_the_transport_cannot_address_are_refused() -> None:
    profile = _variant("cia402", axes__device_ids={"x": 0, "y": 255, "z": 247})
    ModbusLink(transport="tcp", host="127.0.0.1", port=1).check_device_id(255)
    ModbusLink(transport="tcp", host="127.0.0.1", port=1).check_device_id(0)
    rtu = ModbusLink(transport="rtu", serial_port="/dev/null")
    for bad in (0, 248, 255):
        with pytest.raises(ValueError, match=f"device id {bad} is outside 1..247"):
            rtu.check_device_id(bad)
    with pytest.raises(ValueError, match="device id 0 is outside 1..247 for Modbus RTU"):
        AxisController(profile, rtu)
    with pytest.raises(ProfileError, match=r"\[axes.device_ids.x\] must be 0..255"):
        _variant("cia402", axes__device_ids={"x": 256})


def test_functions_must_cover_what_the_profile_uses() -> None:
    with pytest.raises(ProfileError, match=r"\[values.servo_on_command.function\] a coil needs"):
        _variant("iai-pcon", transport={"functions": [3, 16]})
    with pytest.raises(ProfileError, match=r"\[transport.functions\] must include 16"):
        _variant("cia402", transport={"functions": [3, 6]})
    with pytest.raises(ProfileError, match=r"\[transport.functions\[2\]\] must be one of"):
        _variant("cia402", transport={"functions": [3, 16, 4]})


def test_the_simulator_serves_the_kinco_map_over_rtu() -> None:
    profile = load_profile("kinco-fd")
    model = MotionModel(SimClock(speed=50.0))
    server = ModbusSimServer(profile, model, transport="rtu")
    address = server.start()
    link = ModbusLink.for_profile(profile, transport="rtu", serial_port=str(address.port))
    try:
        c = AxisController(profile, link)
        c.enable()
        c.home()
        assert c.move_to({"x": 3.0, "y": 0.0, "z": -2.0})["z"].position_mm == pytest.approx(-2.0)
        c.move_to({"x": -90.0}, speed_mm_s=5.0, wait=False)
        c.stop(["x"])
        stopped = model.raw_position_mm("x")
        c.reset_alarms()
        c.enable()
        assert model.raw_position_mm("x") == stopped and -90.0 < stopped < 3.0
    finally:
        link.close()
        server.stop()


def test_status_reads_stay_within_125_registers_a_request() -> None:
    """FC 3 reads 1 to 125 registers (Modbus Application Protocol V1.1b3 §6.3): status
    values chained within the profile's gap allowance get a second request beyond it."""
    raw = tomllib.loads(Path(load_profile("iai-pcon").source).read_text(encoding="utf-8"))
    raw["status"]["max_gap_registers"] = 32
    link = ModbusLink.for_profile(load_profile("iai-pcon"), transport="tcp", port=1)

    def reads(offsets: list[int]) -> tuple[tuple[int, int], ...]:
        for i, offset in enumerate(offsets):  # each 32 registers after the one before
            raw["values"][f"far_{i}"] = {"address": 0x9000 + offset, "function": "holding",
                                         "type": "u16", "unit": "raw", "access": "r"}
            raw["flags"][f"far_{i}"] = {"value": f"far_{i}", "bit": 0}
        return AxisController(parse_profile(raw, source="variant"), link).status_reads

    assert reads([40, 73, 106, 124]) == ((0x9000, 125),)
    assert reads([40, 73, 106, 139]) == ((0x9000, 107), (0x9000 + 139, 1))


def test_a_write_block_beyond_123_registers_is_refused_when_the_profile_loads() -> None:
    """FC 16 writes 1 to 123 registers (V1.1b3 §6.12)."""
    raw = tomllib.loads(Path(load_profile("iai-pcon").source).read_text(encoding="utf-8"))
    names = [f"block_{i}" for i in range(62)]  # 62 × 2 = 124 registers
    for i, name in enumerate(names):
        raw["values"][name] = {"address": 0xA000 + 2 * i, "function": "holding",
                               "type": "s32", "unit": "raw", "access": "rw"}
    raw["commands"]["move"]["start"] = [{"op": "write_block", "to": names,
                                         "value": [0] * len(names), "edge": True}]
    with pytest.raises(ProfileError, match=r"\[commands.move.start\[0\].to\] 124 registers"):
        parse_profile(raw, source="iai-pcon variant")
    raw["commands"]["move"]["start"][0].update(to=names[:61], value=[0] * 61)
    parse_profile(raw, source="iai-pcon variant")  # 122 registers: one request
