"""The pre-flight check against a simulated drive whose word order or home-offset sign
differs from the client's profile: it stops before the second move and names the field."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from ogacq_drivers.axes.controller import AxisController
from ogacq_drivers.axes.modbus_link import ModbusLink
from ogacq_drivers.axes.preflight import PreflightError, check_home, check_identity, run_preflight
from ogacq_drivers.axes.profile import Profile, load_profile, parse_profile
from tests.drivers.drive_rig import simulated_drive
from tests.emulators.drives import Cia402Drive, EmulatorServer

pytestmark = pytest.mark.filterwarnings("ignore:isSet:DeprecationWarning")


def _variant(name: str, table: str, **values: object) -> Profile:
    raw = tomllib.loads(Path(load_profile(name).source).read_text(encoding="utf-8"))
    raw[table].update(values)
    return parse_profile(raw, source=f"{name} with {table} {values}")


@pytest.mark.parametrize("name", ["cia402", "iai-pcon"])
def test_a_drive_as_the_profile_says_passes(name: str) -> None:
    profile = load_profile(name)
    with simulated_drive(profile, profile) as (c, model, _server, _link):
        c.enable()
        c.home()
        run_preflight(c, probe_mm=1.0)
        assert [model.raw_position_mm(a) for a in "xyz"] == pytest.approx([1.0] * 3, abs=0.011)


def test_wrong_word_order_stops_before_the_probe_move() -> None:
    drive = load_profile("cia402")
    client = _variant("cia402", "codec", word_order="high_first")
    with simulated_drive(drive, client) as (c, model, _server, _link):
        c.enable()
        c.home()
        with pytest.raises(PreflightError, match="change codec.word_order") as caught:
            run_preflight(c, probe_mm=1.0)
        assert caught.value.field == "codec.word_order"
        assert [model.raw_position_mm(a) for a in "xyz"] == [0.0, 0.0, 0.0]
        assert "\n" not in str(caught.value)


def test_wrong_home_offset_sign_stops_after_homing() -> None:
    drive = load_profile("cia402")  # the drive: home point reads -home_offset
    client = _variant("cia402", "offset", sign=1)
    with simulated_drive(drive, client) as (c, model, server, _link):
        for unit in server.devices.values():
            unit.put("home_offset", 0.5)  # set on the drive's panel before
        c.enable()
        homed_writes = []
        with pytest.raises(PreflightError, match="change offset.sign to -1") as caught:
            c.home()  # a homing seen done at once at the opposite value says so here,
            homed_writes.append(c.link.stats.writes)
            check_home(c)  # one seen under way, here
        assert caught.value.field == "offset.sign"
        assert c.link.stats.writes == (homed_writes or [c.link.stats.writes])[0]  # nothing written
        assert [model.raw_position_mm(a) for a in "xyz"] == [0.0, 0.0, 0.0]


def test_a_status_bit_read_from_the_wrong_place_is_named() -> None:
    drive = load_profile("iai-pcon")
    raw = tomllib.loads(Path(drive.source).read_text(encoding="utf-8"))
    raw["flags"]["moving"] = {"value": "device_status_1", "bit": 12}  # SV, not MOVE
    client = parse_profile(raw, source="iai-pcon with moving on the servo bit")
    with simulated_drive(drive, client) as (c, _model, _server, _link):
        check_identity(c)  # servo off: nothing contradicts yet
        drive_side = AxisController(drive, c.link)
        drive_side.enable(["x"])
        with pytest.raises(PreflightError, match="in position and moving at once") as caught:
            check_identity(c, ["x"])
        assert caught.value.field == "flags.moving"


def test_a_device_that_is_no_cia402_drive_is_named() -> None:
    drive = load_profile("cia402")
    raw = tomllib.loads(Path(drive.source).read_text(encoding="utf-8"))
    raw["values"]["statusword"]["address"] = 0x6060  # reads the mode (1): no CiA 402 state
    raw["values"]["mode"]["address"] = 0x6041
    client = parse_profile(raw, source="cia402 with statusword and mode swapped")
    with simulated_drive(drive, client) as (c, _model, _server, _link):
        with pytest.raises(PreflightError, match="is no CiA 402 state") as caught:
            check_identity(c, ["x"])
        assert caught.value.field == "values.statusword.address"


def test_a_drive_that_homes_at_once_shows_the_opposite_sign_as_such() -> None:
    """The independent emulator applies its home offset with the sign opposite to the
    profile's and homes where it stands (as CiA 402 methods 35 and 37: no motion to
    see): the homing after an offset write names offset.sign at once, not "not
    acknowledged" after the acknowledge timeout."""
    server = EmulatorServer("tcp")
    drive = server.add(1, Cia402Drive, home_sign=+1)
    profile = load_profile("cia402")  # sign -1
    link = ModbusLink.for_profile(profile, transport="tcp", host="127.0.0.1",
                                  port=server.start())
    try:
        c = AxisController(profile, link, axes=["x"])
        c.enable()
        c.home()  # home offset 0: either sign reads 0
        c.write_offsets({"x": 0.25})
        with pytest.raises(PreflightError, match=r"done at \+0.2500 mm, the opposite of the "
                                                 r"-0.2500 mm.*change offset.sign to \+1",
                           ) as caught:
            c.home()
    finally:
        link.close()
        server.stop()
    assert caught.value.field == "offset.sign"
    assert drive.physical_counts() == 0.0  # it never moved
