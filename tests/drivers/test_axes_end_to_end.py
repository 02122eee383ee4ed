"""The axis controller against the simulated controller, through real pymodbus on the wire.

Every test runs the real codec: AxisController -> ModbusLink -> pymodbus client ->
TCP on 127.0.0.1 or RTU over the paced pty bridge (38400 baud) -> pymodbus server ->
simulated controller -> motion model. SimClock(speed=50) makes the moves short.
"""

from __future__ import annotations

import dataclasses
import socket
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

import pytest
from pymodbus.client import ModbusTcpClient

from ogacq_drivers.axes.controller import AxisController
from ogacq_drivers.axes.modbus_link import ModbusLink
from ogacq_drivers.axes.profile import Profile, load_profile
from ogacq_drivers.errors import DeviceFault, DeviceTimeout, DriverError, LinkError
from ogacq_drivers.sim.clock import SimClock
from ogacq_drivers.sim.modbus_server import ModbusSimServer
from ogacq_drivers.sim.motion import MotionModel
from ogacq_drivers.sim.ptybridge import PtyBridge

X_LEG_MAX = {"x": 60.0, "y": -5.84, "z": -5.84}  # posture of the paper (approx.)
Y_LEG_MAX = {"x": -5.84, "y": 60.0, "z": -5.84}
RIGS = [("iai-pcon", "rtu"), ("iai-pcon", "tcp"), ("cia402", "tcp"), ("cia402", "rtu")]


@dataclass
class Rig:
    profile: Profile
    model: MotionModel
    server: ModbusSimServer
    link: ModbusLink
    controller: AxisController


def _link_to(profile: Profile, transport: str, address) -> ModbusLink:  # type: ignore[no-untyped-def]
    if transport == "tcp":
        return ModbusLink.for_profile(
            profile, transport="tcp", host=address.host, port=address.port
        )
    return ModbusLink.for_profile(profile, transport="rtu", serial_port=address.port)


@contextmanager
def rig(
    name: str, transport: str, *, speed: float = 50.0, profile: Profile | None = None
) -> Iterator[Rig]:
    profile = profile or load_profile(name)
    model = MotionModel(SimClock(speed=speed))
    server = ModbusSimServer(profile, model, transport=transport)  # type: ignore[arg-type]
    address = server.start()
    link = _link_to(profile, transport, address)
    try:
        yield Rig(profile, model, server, link, AxisController(profile, link))
    finally:
        link.close()
        server.stop()


def patient(profile: Profile) -> Profile:
    """The profile with a reply timeout a loaded 2-core CI keeps (the simulator answers
    from a thread of the same busy machine, once seen later than a profile's 0.2 s): the
    tests of motion are about the commands; the timeout's own tests keep the profile's."""
    transport = dataclasses.replace(profile.transport,
                                    timeout_s=max(profile.transport.timeout_s, 2.0))
    return dataclasses.replace(profile, transport=transport)


@pytest.fixture(params=RIGS, ids=[f"{p}-{t}" for p, t in RIGS])
def ready(request: pytest.FixtureRequest) -> Iterator[Rig]:
    """Enabled and homed, all three axes at q = 0."""
    name, transport = request.param
    with rig(name, transport, profile=patient(load_profile(name))) as r:
        r.controller.enable()
        r.controller.home()
        yield r


def test_enable_home_and_move_to_paper_postures(ready: Rig) -> None:
    c, model = ready.controller, ready.model
    status = c.read_status()
    assert all(s.servo_on and s.homed and s.in_position and not s.fault for s in status.values())
    for posture in (X_LEG_MAX, Y_LEG_MAX, {"x": 0.0, "y": 0.0, "z": 0.0}):
        reached = c.move_to(posture)
        for axis, q in posture.items():
            assert reached[axis].position_mm == pytest.approx(q, abs=0.011)
            assert model.raw_position_mm(axis) == pytest.approx(q, abs=0.011)
        assert c.read_positions() == pytest.approx(posture, abs=0.011)
    # last moves, from Y_LEG_MAX back to 0: x and z up, y down
    assert [model.last_direction(a) for a in "xyz"] == [1, -1, 1]


def test_status_poll_is_one_block_per_contiguous_run(ready: Rig) -> None:
    before = ready.link.stats.reads
    ready.controller.read_status()
    per_device = {"iai-pcon": 1, "cia402": 2}[ready.profile.name]
    assert ready.link.stats.reads - before == 3 * per_device
    if ready.profile.name == "iai-pcon":
        assert ready.controller.status_reads == ((0x9000, 8),)


def test_soft_limit_alarm_then_reset(ready: Rig) -> None:
    c, model, profile = ready.controller, ready.model, ready.profile
    writes = ready.link.stats.writes
    with pytest.raises(ValueError, match="outside the soft limits"):
        c.move_to({"x": 70.0})
    assert ready.link.stats.writes == writes  # refused before anything was sent
    with pytest.raises(DeviceFault) as caught:
        c.move_to({"x": 70.0}, check_limits=False)  # beyond the controller's own limit + margin
    code = profile.sim.soft_limit_alarm_code
    assert caught.value.code == code
    assert "device 1 (axis x)" in str(caught.value)
    assert model.raw_position_mm("x") == 0.0  # no motion
    assert c.read_alarms() == {"x": code, "y": 0, "z": 0}
    assert c.read_status()["x"].fault
    with pytest.raises(DeviceFault, match="in alarm"):
        c.move_to({"x": 10.0})
    assert c.reset_alarms() == {"x": code}
    c.enable()  # a CiA 402 drive comes out of fault disabled
    assert c.read_alarms()["x"] == 0
    assert c.move_to({"x": 10.0})["x"].position_mm == pytest.approx(10.0)
    assert c.reset_alarms() == {}  # nothing in alarm: nothing written


def test_stop_interrupts_a_move_and_recovery_does_not_resume_it(ready: Rig) -> None:
    c, model = ready.controller, ready.model
    clock = model.clock
    # the machine held still while the test looks, so that it is mid-move however late
    # a loaded machine runs the requests (CiA 402 over paced RTU: a status check and the
    # set-point handshake took longer than the move once)
    clock.hold()
    c.move_to({"x": -90.0}, speed_mm_s=5.0, wait=False)
    clock.advance(2.0)  # 10 mm of the 90 (after its ramp up)
    assert c.read_status(["x"])["x"].moving
    c.stop()
    stopped = model.raw_position_mm("x")
    assert -90.0 < stopped < 0.0
    assert not model.has_paused_move("x")  # cancelled, not paused
    clock.advance(1.0)  # settled where it stopped
    # the campaign's recovery path: alarm reset, enable (a CiA 402 quick stop disables)
    c.reset_alarms()
    c.enable()
    status = c.wait_in_position(["x"], timeout_s=2.0)["x"]
    assert not status.moving and status.position_mm == pytest.approx(stopped, abs=0.011)
    clock.advance(5.0)  # a resumed move would be 25 mm further
    assert model.raw_position_mm("x") == stopped
    clock.release()
    assert c.move_to({"x": 5.0})["x"].position_mm == pytest.approx(5.0)


def test_offsets_shift_commanded_and_reported_positions(ready: Rig) -> None:
    c, model = ready.controller, ready.model
    assert c.read_offsets() == {"x": 0.0, "y": 0.0, "z": 0.0}
    change = c.write_offsets({"x": 0.5, "y": -0.25})
    assert change.old_mm == {"x": 0.0, "y": 0.0}
    assert change.new_mm == {"x": 0.5, "y": -0.25}
    assert c.read_offsets() == pytest.approx({"x": 0.5, "y": -0.25, "z": 0.0})
    if ready.profile.offset.kind == "home_offset":
        assert change.takes_effect == "at_next_homing" and change.written_to_device
        assert c.rehome_required == {"x", "y"}
        # the object is in the drive; sign -1: object = offset
        raw_object = ready.link.read_registers(1, 0x607C, 2)
        assert ready.profile.decode("home_offset", raw_object) == pytest.approx(0.5)
        c.move_to({"x": 10.0})
        assert model.raw_position_mm("x") == pytest.approx(10.0)  # not effective before homing
        c.home()
        assert not c.rehome_required
        assert model.raw_position_mm("x") == 0.0  # home is the mechanical zero...
        assert c.read_positions()["x"] == pytest.approx(-0.5)  # ...which now reads q = -o
    else:
        assert change.takes_effect == "now" and not change.written_to_device
        assert c.software_offsets_mm == {"x": 0.5, "y": -0.25, "z": 0.0}
    c.move_to({"x": 10.0, "y": 10.0, "z": 10.0})
    assert c.read_positions() == pytest.approx({"x": 10.0, "y": 10.0, "z": 10.0}, abs=0.011)
    raw = {a: model.raw_position_mm(a) for a in "xyz"}
    assert raw == pytest.approx({"x": 10.5, "y": 9.75, "z": 10.0}, abs=0.011)


def test_offsets_beyond_the_margin_need_force(ready: Rig) -> None:
    with pytest.raises(ValueError, match="exceed the 2 mm margin"):
        ready.controller.write_offsets({"z": 2.5})
    assert ready.controller.write_offsets({"z": 2.5}, force=True).new_mm == {"z": 2.5}


@pytest.mark.parametrize("name", ["iai-pcon", "cia402"])
def test_save_to_nvm_only_where_there_is_one(name: str) -> None:
    with rig(name, "tcp") as r:
        if r.profile.nvm.kind == "none":
            with pytest.raises(DriverError, match="nothing to save"):
                r.controller.save_to_nvm()
            return
        assert all(d.nvm_saves == 0 for d in r.server.devices.values())  # type: ignore[attr-defined]
        r.controller.write_offsets({"x": 0.1})
        assert all(d.nvm_saves == 0 for d in r.server.devices.values())  # type: ignore[attr-defined]
        r.controller.save_to_nvm(["x"])
        assert [d.nvm_saves for d in r.server.devices.values()] == [1, 0, 0]  # type: ignore[attr-defined]


def test_unacknowledged_move_is_not_resent() -> None:
    profile = load_profile("iai-pcon")
    quick = dataclasses.replace(
        profile, timing=dataclasses.replace(profile.timing, ack_timeout_s=0.2)
    )
    with rig("iai-pcon", "tcp", profile=quick) as r:
        r.controller.enable(["x"])
        r.controller.home(["x"])
        # someone took Modbus control away: the controller ignores the move
        r.link.write_coil(1, profile.value("modbus_control").address, False, what="test: PMSL off")
        sent = _record_writes(r.link)
        with pytest.raises(DeviceTimeout, match="not acknowledged.*not re-sent"):
            r.controller.move_to({"x": 20.0})
        # the move block once, then the deceleration stop a failed move ends with
        move_block = profile.value("move_target").address
        stop = profile.value("decel_stop_command").address
        assert sent == [("registers", move_block), ("coil", stop, True)]
        assert r.model.raw_position_mm("x") == 0.0


def _record_writes(link: ModbusLink) -> list[tuple]:
    """What the controller writes from now on: (kind, address[, coil state])."""
    sent: list[tuple] = []
    register, registers, coil = link.write_register, link.write_registers, link.write_coil

    def one(device_id, address, value, *, what):  # type: ignore[no-untyped-def]
        sent.append(("register", address, value))
        register(device_id, address, value, what=what)

    def block(device_id, address, values, *, what):  # type: ignore[no-untyped-def]
        sent.append(("registers", address))
        registers(device_id, address, values, what=what)

    def bit(device_id, address, value, *, what):  # type: ignore[no-untyped-def]
        sent.append(("coil", address, value))
        coil(device_id, address, value, what=what)

    link.write_register, link.write_registers, link.write_coil = one, block, bit  # type: ignore[method-assign]
    return sent


def test_move_refused_when_servo_off_or_not_homed() -> None:
    with rig("cia402", "tcp") as r:
        with pytest.raises(DeviceFault, match="servo is off"):
            r.controller.move_to({"x": 1.0})
        r.controller.enable()
        with pytest.raises(DeviceFault, match="not homed"):
            r.controller.move_to({"x": 1.0})
        r.controller.disable(["y"])
        assert not r.controller.read_status()["y"].servo_on


# ------------------------------------------------------------------ dead devices


def _free_tcp_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def test_nothing_listening_on_tcp_is_a_link_error_at_once() -> None:
    profile = load_profile("cia402")
    link = ModbusLink.for_profile(profile, transport="tcp", port=_free_tcp_port())
    started = time.monotonic()
    with pytest.raises(LinkError, match=r"modbus tcp 127\.0\.0\.1:\d+ device 1"):
        AxisController(profile, link).read_status()
    assert time.monotonic() - started < 1.0


@pytest.mark.parametrize("transport", ["tcp", "rtu"])
def test_server_stopped_reports_within_bounded_time(transport: str) -> None:
    profile = load_profile("iai-pcon")
    bound_s = profile.transport.timeout_s * (profile.transport.read_retries + 1)
    with PtyBridge(baudrate=profile.transport.baudrate) as bridge:
        model = MotionModel(SimClock(speed=50.0))
        server = ModbusSimServer(
            profile,
            model,
            transport=transport,  # type: ignore[arg-type]
            serial_port=bridge.server_path if transport == "rtu" else None,
        )
        address = server.start()
        if transport == "rtu":
            assert address.port == bridge.server_path  # the caller owns the cable here
            link = ModbusLink.for_profile(profile, transport="rtu", serial_port=bridge.client_path)
        else:
            link = _link_to(profile, transport, address)
        controller = AxisController(profile, link)
        controller.read_status()
        server.stop()
        started = time.monotonic()
        with pytest.raises((DeviceTimeout, LinkError)) as caught:
            controller.read_status()
        elapsed = time.monotonic() - started
        link.close()
    assert elapsed <= bound_s + 0.3
    assert "device 1" in str(caught.value) and "0x9000" in str(caught.value)
    if transport == "rtu":  # a silent line: every attempt timed out
        assert isinstance(caught.value, DeviceTimeout)
        assert elapsed >= bound_s * 0.9


@pytest.mark.parametrize("transport", ["tcp", "rtu"])
def test_absent_device_id_is_a_timeout(transport: str) -> None:
    with rig("iai-pcon", transport) as r:
        started = time.monotonic()
        with pytest.raises(DeviceTimeout, match="device 9"):
            r.link.read_registers(9, 0x9000, 8)
        assert time.monotonic() - started < 2 * r.profile.transport.timeout_s + 0.3


# ------------------------------------------------------------------ independent client


def test_cia402_sim_serves_a_plain_pymodbus_client() -> None:
    """The sequence of shared/checks/sim_contract.py, without any ogacq code on the client side."""
    model = MotionModel(SimClock(speed=50.0))
    with ModbusSimServer("cia402", model, transport="tcp") as server:
        info = server.address.as_dict()
        assert set(info) == {"transport", "host", "port", "profile", "device_ids"}
        client = ModbusTcpClient(info["host"], port=info["port"], timeout=2, retries=0)
        assert client.connect()
        dev = info["device_ids"]["x"]

        def read(address: int, count: int = 1) -> list[int]:
            response = client.read_holding_registers(address, count=count, device_id=dev)
            assert not response.isError()
            return list(response.registers)

        def write(address: int, value: int) -> None:
            assert not client.write_register(address, value, device_id=dev).isError()

        def wait(bit: int) -> bool:
            end = time.time() + 5
            while time.time() < end:
                if read(0x6041)[0] & (1 << bit):
                    return True
                time.sleep(0.01)
            return False

        def position() -> int:
            lo, hi = read(0x6064, 2)
            value = (hi << 16) | lo
            return value - (1 << 32) if value & 0x80000000 else value

        for cw in (0x06, 0x07, 0x0F):
            write(0x6040, cw)
        write(0x6060, 6)
        write(0x6040, 0x0F)
        write(0x6040, 0x1F)
        assert wait(12) and wait(10)
        write(0x6060, 1)
        target = position() + 2000
        assert not client.write_registers(
            0x607A, [target & 0xFFFF, (target >> 16) & 0xFFFF], device_id=dev
        ).isError()
        write(0x6040, 0x0F)
        write(0x6040, 0x1F)
        assert wait(10)
        write(0x6040, 0x0F)
        assert abs(position() - target) <= 2
        assert model.raw_position_mm("x") == pytest.approx(20.0)
        client.close()


def test_rtu_address_info_and_loopback_only() -> None:
    model = MotionModel(SimClock())
    with ModbusSimServer("iai-pcon", model) as server:
        info = server.address.as_dict()
        assert info["transport"] == "rtu" and info["host"] is None
        assert info["port"].startswith("/dev/") and info["baudrate"] == 38400
        assert info["device_ids"] == {"x": 1, "y": 2, "z": 3}
    with pytest.raises(ValueError, match="loopback only"):
        ModbusSimServer("cia402", model, host="0.0.0.0")


def _written_objects(sent: list[tuple], profile: Profile) -> list[str]:
    names = {spec.address: name for name, spec in profile.values.items()}
    return [names[entry[1]] for entry in sent]


def test_settings_the_drive_keeps_are_written_again_only_when_unknown() -> None:
    with rig("cia402", "tcp") as r:
        c, profile = r.controller, r.profile
        c.enable()
        c.home()  # ends with mode 1 and controlword 0x0F: both known
        sent = _record_writes(r.link)
        c.move_to({"x": 10.0})
        assert _written_objects(sent, profile) == [
            "profile_velocity", "target_position", "controlword", "controlword"]
        sent.clear()
        c.move_to({"x": 20.0})  # same speed: target and the set-point handshake only
        assert _written_objects(sent, profile) == [
            "target_position", "controlword", "controlword"]
        sent.clear()
        c.move_to({"x": 10.0}, speed_mm_s=50.0)  # a new speed is written
        assert _written_objects(sent, profile)[0] == "profile_velocity"

        # A failed transaction: what the drive holds is no longer known.
        with pytest.raises(DriverError):
            r.link.read_registers(1, 0x1234, 1)
        sent.clear()
        c.move_to({"x": 20.0}, speed_mm_s=50.0)
        assert _written_objects(sent, profile) == [
            "mode", "profile_velocity", "target_position", "controlword", "controlword",
            "controlword"]

        # A fault seen and cleared: written again too (enable rewrites the mode).
        r.model.inject_alarm("x")
        with pytest.raises(DeviceFault, match="in alarm"):
            c.move_to({"x": 10.0}, speed_mm_s=50.0)
        c.reset_alarms()
        c.enable()
        sent.clear()
        c.move_to({"x": 10.0}, speed_mm_s=50.0)
        assert _written_objects(sent, profile)[:2] == ["profile_velocity", "target_position"]
        assert r.model.raw_position_mm("x") == pytest.approx(10.0, abs=0.011)


@pytest.mark.parametrize("name", ["cia402", "iai-pcon"])
def test_a_move_failing_on_one_axis_stops_the_others(name: str) -> None:
    with rig(name, "tcp") as r:
        c, model = r.controller, r.model
        c.enable()
        c.home()
        # 18 s simulated at 5 mm/s, 0.36 s real: the alarm comes half way
        timer = threading.Timer(0.15, model.inject_alarm, ("y",))
        timer.start()
        try:
            with pytest.raises(DeviceFault, match="axis y in alarm"):
                c.move_to({"x": -90.0, "y": -90.0, "z": -90.0}, speed_mm_s=5.0)
        finally:
            timer.join()
        stopped = {a: model.raw_position_mm(a) for a in "xz"}
        time.sleep(0.05)
        for axis, where in stopped.items():
            assert -90.0 < where < 0.0
            assert model.raw_position_mm(axis) == where  # halted, not still going


def test_arrival_is_confirmed_by_flags_then_one_position_read_per_axis() -> None:
    with rig("cia402", "tcp") as r:
        c, profile = r.controller, r.profile
        c.enable()
        c.home()
        read_addresses: list[int] = []
        read = r.link.read_registers

        def counted(device_id, address, count):  # type: ignore[no-untyped-def]
            read_addresses.append(address)
            return read(device_id, address, count)

        r.link.read_registers = counted  # type: ignore[method-assign]
        reached = c.move_to({"x": -40.0, "y": 30.0, "z": -10.0})
        assert {a: s.position_mm for a, s in reached.items()} == pytest.approx(
            {"x": -40.0, "y": 30.0, "z": -10.0}, abs=0.011)
        position = profile.value("position_actual").address
        assert read_addresses.count(position) == 3  # on arrival only
        assert read_addresses.count(profile.value("statusword").address) >= 3 + 3 + 3


def test_every_axis_is_checked_then_the_longest_travel_starts_first() -> None:
    # The move ends with its longest travel: started first, the other axes' start
    # requests no longer add to the time the move takes. Nothing starts before all
    # three axes were checked (fault, servo on).
    with rig("cia402", "tcp") as r:
        c, profile = r.controller, r.profile
        c.enable()
        c.home()
        c.move_to({"x": 0.0, "y": 10.0, "z": 0.0})
        traffic: list[tuple[str, int, int]] = []
        read, write_one = r.link.read_registers, r.link.write_register

        def reading(device_id, address, count):  # type: ignore[no-untyped-def]
            traffic.append(("read", device_id, address))
            return read(device_id, address, count)

        def writing(device_id, address, value, *, what):  # type: ignore[no-untyped-def]
            traffic.append((f"write {value:#x}", device_id, address))
            write_one(device_id, address, value, what=what)

        r.link.read_registers, r.link.write_register = reading, writing  # type: ignore[method-assign]
        # travels: x 5 mm, y 50 mm (from 10), z 20 mm
        reached = c.move_to({"x": -5.0, "y": -40.0, "z": 20.0})
        assert list(reached) == ["x", "y", "z"]
        controlword = profile.value("controlword").address
        starts = [device for kind, device, address in traffic
                  if kind == "write 0x1f" and address == controlword]
        assert starts == [profile.device_ids[a] for a in ("y", "z", "x")]
        first_write = next(i for i, (kind, _, _) in enumerate(traffic) if kind != "read")
        assert sorted(device for _, device, _ in traffic[:first_write]) == [1, 2, 3]
        assert r.model.raw_position_mm("y") == pytest.approx(-40.0, abs=0.011)
