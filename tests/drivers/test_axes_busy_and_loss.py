"""What the axis client does when a drive says it is busy, or loses its power or its
reference between two polls, against the modbus_tk emulators written from the manuals
(tests/emulators/drives.py).

- Exception 6 "server device busy" (Modbus Application Protocol V1.1b3 §7): the
  request was not executed and "the client should retransmit the message later". A
  read is asked again after the link's timeout; a write is reported, never re-sent.
- A drive switched off and on (between two polls, or in the middle of a move): its
  counter restarts where the axis stands, so no arrival and no later set-point may
  rest on the homing done before.
"""

from __future__ import annotations

import time

import pytest

from ogacq_drivers.errors import DeviceBusy, DeviceFault
from tests.drivers.test_axes_independent_server import bench

pytestmark = pytest.mark.filterwarnings("ignore:isSet:DeprecationWarning")


def test_a_busy_read_is_asked_again_and_then_answered() -> None:
    with bench("iai-pcon", "tcp") as b:
        x = b.drives["x"]
        before = b.controller.link.stats
        x.busy_replies = 1
        status = b.controller.read_status(["x"])["x"]
        assert not status.fault and x.busy_replies == 0
        assert b.controller.link.stats.read_retries == before.read_retries + 1


def test_a_drive_busy_for_longer_is_named_with_exception_6() -> None:
    with bench("iai-pcon", "tcp") as b:
        x = b.drives["x"]
        x.busy_replies = 10
        with pytest.raises(DeviceBusy, match=r"exception 6 \(device busy\), still after 2 "
                                             r"attempt") as busy:
            b.controller.read_status(["x"])
        assert busy.value.code == 6
        assert x.busy_replies == 8  # read_retries = 1: two requests, no more


def test_a_busy_write_is_reported_not_executed_and_not_sent_again() -> None:
    with bench("iai-pcon", "tcp") as b:
        x = b.drives["x"]
        sent = len(x.requests)
        x.busy_replies = 1
        with pytest.raises(DeviceBusy, match="did not execute it; not re-sent"):
            b.controller.disable(["x"])  # its first request is the write (SON off)
        writes = [pdu for pdu in x.requests[sent:] if pdu[0] in (5, 6, 15, 16)]
        assert len(writes) == 1  # the refused write, once; nothing after it


# ----------------------------------------------------------------- a drive switched off and on
# A CiA 402 drive has no bit saying it is homed outside homing mode; switched off and on
# between two polls it answers as before, in "switch on disabled", its incremental
# counter restarted wherever the axis stands (tests/emulators/drives.py power_cycle).


def test_cia402_switched_off_and_on_between_polls_is_not_moved_on_its_old_homing() -> None:
    with bench("cia402", "tcp") as b:
        c, x = b.controller, b.drives["x"]
        c.enable(["x"])
        c.home(["x"])
        c.move_to({"x": -5.0})
        x.power_cycle(counter_at_power_on=0)
        c.enable(["x"])
        with pytest.raises(DeviceFault, match="not homed") as refused:
            c.move_to({"x": -10.0})
        assert refused.value.code == "not_homed"
        assert not any(what.startswith("set-point") for _, what in
                       x.events[[e for _, e in x.events].index("power cycle"):])


def test_a_disable_or_a_stop_by_this_client_keeps_the_homing() -> None:
    with bench("cia402", "tcp") as b:
        c = b.controller
        c.enable(["x"])
        c.home(["x"])
        c.disable(["x"])
        c.enable(["x"])
        c.move_to({"x": -1.0})
        c.stop(["x"])  # quick stop option code 2: ends in "switch on disabled"
        c.enable(["x"])
        assert c.move_to({"x": -2.0})["x"].position_mm == pytest.approx(-2.0)


@pytest.mark.parametrize("name", ["cia402", "iai-pcon"])
def test_a_drive_switched_off_and_on_mid_move_is_no_arrival(name: str) -> None:
    """Its counter restarts at the very target: in position, at the target, and not
    vouched for."""
    with bench(name, "tcp") as b:
        c, x = b.controller, b.drives["x"]
        c.enable(["x"])
        c.home(["x"])
        c.move_to({"x": -20.0}, speed_mm_s=10.0, wait=False)
        time.sleep(0.3)
        x.power_cycle(counter_at_power_on=-2000)  # reads -20.00 mm, at rest
        with pytest.raises(DeviceFault, match="servo went off|no longer homed"):
            c.wait_in_position({"x": -20.0}, timeout_s=5.0)
