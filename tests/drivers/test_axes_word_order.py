"""A wrong 32-bit word order is refused before the first set-point, against the
independent emulator (modbus_tk, tests/emulators/drives.py): the drive holds its
32-bit objects high word first, the client's profile says low word first. The
emulator's request log counts what reached it: no target written, no new
set-point, no homing started; the refusal names ``codec.word_order`` and the
evidence, with and without a home offset. Where nothing read can tell (an axis
at counter 0 with no home offset), the probe move's speed reads 1 count/s to the
mismatched drive: it is seen at its first count and stopped there."""

from __future__ import annotations

import struct
import time

import pytest

from ogacq_drivers.axes.controller import AxisController
from ogacq_drivers.axes.modbus_link import ModbusLink
from ogacq_drivers.axes.preflight import PreflightError, check_identity, probe_move
from ogacq_drivers.axes.profile import load_profile
from ogacq.campaign.station import DeviceStation
from tests.emulators.drives import Cia402Drive, EmulatorServer

pytestmark = pytest.mark.filterwarnings("ignore:isSet:DeprecationWarning")

TARGET, CONTROLWORD = 0x607A, 0x6040


def setpoints(drive: Cia402Drive) -> int:
    """Requests that could start a motion: a target written (FC 6/16 at 607Ah) or a
    controlword with bit 4 (new set-point / start homing)."""
    count = 0
    for pdu in drive.requests:
        if pdu[0] not in (6, 16):
            continue
        address = struct.unpack(">H", pdu[1:3])[0]
        if address == TARGET:
            count += 1
        elif address == CONTROLWORD:
            value = struct.unpack(">H", pdu[3:5] if pdu[0] == 6 else pdu[6:8])[0]
            count += bool(value & 0x10)
    return count


def station_on(drives: dict[str, Cia402Drive], port: int) -> DeviceStation:
    profile = load_profile("cia402")  # low word first
    link = ModbusLink.for_profile(profile, transport="tcp", host="127.0.0.1", port=port)
    return DeviceStation(AxisController(profile, link), {}, time.monotonic)


@pytest.mark.parametrize("home_offset_counts", [0, 50])
def test_a_wrong_word_order_is_refused_before_any_setpoint(home_offset_counts: int) -> None:
    server = EmulatorServer("tcp")
    drives = {a: server.add(u, Cia402Drive, high_first=True)
              for a, u in {"x": 1, "y": 2, "z": 3}.items()}
    for drive in drives.values():
        drive.motion.position = 1234.0  # where the axis stands: 12.34 mm on its counter
        drive.put(0x607C, home_offset_counts)
        drive.refresh()
    port = server.start()
    assert port is not None
    station = station_on(drives, port)
    try:
        with pytest.raises(PreflightError) as refused:
            station.prepare()
    finally:
        station.controller.link.close()
        server.stop()
    message = str(refused.value)
    assert refused.value.field == "codec.word_order" and "codec.word_order" in message
    assert "\n" not in message and "nothing was commanded" in message
    # the evidence: what was read, and what it reads the other way round
    assert "+12.34 mm" in message or (home_offset_counts and "+0.50 mm" in message)
    assert sum(setpoints(d) for d in drives.values()) == 0
    assert all(d.motion.now() == 1234.0 for d in drives.values())  # nothing moved


def test_where_nothing_read_can_tell_the_probe_cannot_lurch() -> None:
    """Counter 0, home offset 0: both word orders read the same. The probe's speed,
    0x00010000 counts/s, reads 0x00000001 to the mismatched drive (and its soft
    limits refuse the target it misreads as 65,536 times too far); either way the
    axis moves no more than a count or two and the refusal names the word order."""
    server = EmulatorServer("tcp")
    drive = server.add(1, Cia402Drive, high_first=True)
    drive.limits = None  # a drive without position limits of its own: the worst case
    profile = load_profile("cia402")
    link = ModbusLink.for_profile(profile, transport="tcp", host="127.0.0.1",
                                  port=server.start())
    try:
        controller = AxisController(profile, link, axes=["x"])
        controller.enable()
        controller.home()
        with pytest.raises(PreflightError, match="codec.word_order") as refused:
            probe_move(controller, 1.0)
    finally:
        link.close()
        server.stop()
    assert refused.value.field == "codec.word_order"
    assert abs(drive.physical_counts()) <= 3  # counts: 0.03 mm, not a lurch
    assert drive.motion.speed <= 1.0  # it read 1 count/s


def test_where_every_value_reads_the_same_the_device_type_decides_before_homing() -> None:
    """Counter 0, home offset 0 (both word orders read them alike): the device type,
    profile number 402 in its low word [CiA 301 1000h], read high word first names the
    word order before the homing, the probe or any write."""
    server = EmulatorServer("tcp")
    drives = {a: server.add(u, Cia402Drive, high_first=True)
              for a, u in {"x": 1, "y": 2, "z": 3}.items()}
    port = server.start()
    assert port is not None
    station = station_on(drives, port)
    try:
        with pytest.raises(PreflightError, match="change codec.word_order") as refused:
            station.prepare()
    finally:
        station.controller.link.close()
        server.stop()
    assert refused.value.field == "codec.word_order"
    assert "device_type reads 0x01920002" in str(refused.value)
    writes = [pdu for d in drives.values() for pdu in d.requests if pdu[0] in (5, 6, 15, 16)]
    assert writes == [] and all(not d.events for d in drives.values())


def test_a_device_type_of_no_cia402_drive_is_named() -> None:
    server = EmulatorServer("tcp")
    drive = server.add(1, Cia402Drive)
    drive.put(0x1000, 0x0002_0191)  # CiA 401, an I/O module at the drive's address
    profile = load_profile("cia402")
    link = ModbusLink.for_profile(profile, transport="tcp", host="127.0.0.1",
                                  port=server.start())
    try:
        with pytest.raises(PreflightError, match="check values.device_type.address") as refused:
            check_identity(AxisController(profile, link, axes=["x"]))
    finally:
        link.close()
        server.stop()
    assert refused.value.field == "values.device_type.address"
