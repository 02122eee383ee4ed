"""Whether an axis kept its position reference, asked of the drive itself, against
the independent emulators (modbus_tk, tests/emulators/drives.py): IAI's HEND bit
clears with a power cycle [ME0162 DSS1]; a CiA 402 drive has no such bit, so a
drive that was lost counts as unhomed until homed again, and the client refuses
it a set-point on its own memory of a homing once the link was lost."""

from __future__ import annotations

import pytest

from ogacq_drivers.axes.controller import AxisController
from ogacq_drivers.axes.modbus_link import ModbusLink
from ogacq_drivers.axes.profile import load_profile
from ogacq_drivers.axes.reference import Path, assess_reference
from ogacq_drivers.errors import DeviceFault, LinkError
from tests.campaign.tcp_proxy import FaultyProxy
from tests.drivers.test_axes_independent_server import bench
from tests.emulators.drives import Cia402Drive, EmulatorServer

pytestmark = pytest.mark.filterwarnings("ignore:isSet:DeprecationWarning")


def test_iai_home_end_bit_says_a_power_cycle_lost_the_reference() -> None:
    with bench("iai-pcon", "tcp") as b:
        c, x = b.controller, b.drives["x"]
        c.enable()
        c.home()
        c.move_to({"x": 2.0, "y": 0.0, "z": 0.0}, speed_mm_s=50.0)
        paths = {a: Path(q, q) for a, q in {"x": 2.0, "y": 0.0, "z": 0.0}.items()}
        assert all(r.kept for r in assess_reference(c, paths).values())
        x.power_cycle(counter_at_power_on=0)
        found = assess_reference(c, paths)
        assert not found["x"].kept and found["y"].kept and found["z"].kept
        assert "the drive reports it is not homed" in found["x"].reasons
        assert "not on its way from +2.000 to +2.000 mm" in " ".join(found["x"].reasons)
        with pytest.raises(DeviceFault, match="not homed"):
            c.enable()
            c.move_to({"x": 1.0, "y": 0.0, "z": 0.0})


def test_a_position_off_its_way_or_beyond_the_limits_is_named() -> None:
    with bench("iai-pcon", "tcp") as b:
        c, y = b.controller, b.drives["y"]
        c.enable()
        c.home()
        y.motion.position = 6500.0  # 65 mm, HEND still set: the counter jumped
        found = assess_reference(c, {"y": Path(0.0, 5.0)}, ["y"])["y"]
        assert found.homed and not found.kept
        assert any("outside the soft limits" in r for r in found.reasons)
        assert any("not on its way from +0.000 to +5.000 mm" in r for r in found.reasons)


def test_cia402_lost_link_forgets_the_homing_until_homed_again() -> None:
    profile = load_profile("cia402")
    server = EmulatorServer("tcp")
    drive = server.add(1, Cia402Drive)
    port = server.start()
    assert port is not None
    proxy = FaultyProxy(("127.0.0.1", port)).start()
    link = ModbusLink.for_profile(profile, transport="tcp", host="127.0.0.1", port=proxy.port)
    try:
        c = AxisController(profile, link, axes=["x"])
        c.enable()
        c.home()
        assert assess_reference(c)["x"].kept
        proxy.cut()  # the line drops (the drive may be switched off meanwhile)
        with pytest.raises(LinkError):
            c.read_status()
        link.connect()
        found = assess_reference(c)["x"]
        assert not found.kept and "does not report whether it is homed" in found.reasons[0]
        assert found.describe().startswith("x at +0.000 mm: the drive does not report")
        with pytest.raises(DeviceFault, match="not homed"):
            c.move_to({"x": 1.0})
        assert not any(pdu[0] == 16 and pdu[1:3] == b"\x60\x7a" for pdu in drive.requests)
        c.home()
        assert c.move_to({"x": 1.0})["x"].position_mm == pytest.approx(1.0, abs=0.011)
    finally:
        link.close()
        proxy.close()
        server.stop()
