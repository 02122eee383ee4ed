"""What the axis client does when a drive says it is busy, or loses its power or its
reference between two polls, against the modbus_tk emulators written from the manuals
(tests/emulators/drives.py).

- Exception 6 "server device busy" (Modbus Application Protocol V1.1b3 §7): the
  request was not executed and "the client should retransmit the message later". A
  read is asked again after the link's timeout; a write is reported, never re-sent.
"""

from __future__ import annotations

import pytest

from ogacq_drivers.errors import DeviceBusy
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
            b.controller.enable(["x"])
        writes = [pdu for pdu in x.requests[sent:] if pdu[0] in (5, 6, 15, 16)]
        assert len(writes) == 1  # the refused write, once; nothing after it
