"""The USB-ITN data mode end to end: the real driver and pyusb, a software USB
backend (ogacq_drivers.usb_net) and the simulated cable answering pytuyo's transfers."""

from __future__ import annotations

import re
import subprocess
import sys
import time
from collections.abc import Iterator

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ogacq_drivers.errors import (
    DeviceBusy,
    DeviceFault,
    DeviceTimeout,
    DriverError,
    FrameError,
    LinkError,
    UnitError,
)
from ogacq_drivers.indicators import open_indicator, read_stable
from ogacq_drivers.indicators.usb_itn import CODEC, Message, UsbItn, classify
from ogacq_drivers.sim.gauges import Fault
from ogacq_drivers.sim.usb_itn import UsbItnEndpoint

WHERE = "itn-4"


@pytest.fixture
def cable() -> Iterator[tuple[UsbItnEndpoint, UsbItn]]:
    values = {"mm": 1.2334}
    endpoint = UsbItnEndpoint(lambda: values["mm"]).start()
    endpoint.values = values  # type: ignore[attr-defined]
    gauge = open_indicator("usb-itn", endpoint.port, unit="mm", where=WHERE, timeout_s=3)
    yield endpoint, gauge
    gauge.close()
    endpoint.close()


def test_reads_with_the_documented_transfers(cable):
    endpoint, gauge = cable
    reading = gauge.read()
    assert (reading.value_mm, reading.frame, reading.unit) == (1.233, b"01A+0001.233\r", "mm")
    # pytuyo: 0x40/0x01 wValue 0xA5A5, then 0xC0/0x02 (one byte, 0x01), then 0x40/0x03 "1\r".
    assert endpoint.vendor_transfers == [
        (0x40, 0x01, 0xA5A5, b""),
        (0xC0, 0x02, 0, b""),
        (0x40, 0x03, 0, b"1\r"),
    ]
    assert gauge.device_info() == "SIM-ITN USB-ITN simulated cable 1.0"
    assert not endpoint._kernel_driver  # usbhid let go of the cable while we read it
    endpoint.values["mm"] = -0.5
    assert read_stable(gauge, n=3, tolerance_mm=0.001, timeout_s=2).value_mm == -0.5
    gauge.close()
    assert endpoint._kernel_driver  # given back: the cable types again as a keyboard


def test_stale_replies_are_flushed(cable):
    endpoint, gauge = cable
    gauge.read()
    endpoint.values["mm"] = 2.5
    endpoint.set_fault(Fault.STALE, count=4)  # replies of 1.233 queued in the cable
    stable = read_stable(gauge, n=3, tolerance_mm=0.001, timeout_s=2)
    assert [r.value_mm for r in stable.readings] == [2.5, 2.5, 2.5]


def test_silence_is_a_timeout_naming_the_gauge_then_recovers(cable):
    endpoint, gauge = cable
    endpoint.set_fault(Fault.SILENCE)
    start = time.monotonic()
    with pytest.raises(DeviceTimeout, match=f"{WHERE}: no reply"):
        gauge.read(timeout_s=0.1)
    assert time.monotonic() - start < 5  # bounded by the deadline, not by the cable
    endpoint.clear_fault()
    assert gauge.read().value_mm == 1.233


def test_garbage_is_a_frame_error_then_recovers(cable):
    endpoint, gauge = cable
    endpoint.set_fault(Fault.GARBLED, count=1)
    with pytest.raises(FrameError, match=f"{WHERE}.*#"):
        gauge.read()
    assert gauge.read().value_mm == 1.233


def test_status_codes_busy_error_and_inch(cable):
    endpoint, gauge = cable
    endpoint.set_fault(Fault.BUSY, count=2)
    before = endpoint.requests_received
    assert gauge.read().value_mm == 1.233  # 918 twice, asked again
    assert endpoint.requests_received - before == 3
    endpoint.set_fault(Fault.BUSY)
    with pytest.raises(DeviceBusy, match=WHERE):
        gauge.read(timeout_s=1)
    endpoint.clear_fault()
    endpoint.set_fault(Fault.ERROR, code="911", count=1)
    with pytest.raises(DeviceFault, match=f"{WHERE}.*911.*no data") as fault:
        gauge.read()
    assert fault.value.code == "911"
    endpoint.set_fault(Fault.INCH)
    with pytest.raises(UnitError, match=f"{WHERE}.*inch"):
        gauge.read()  # no unit in the 01A frame: the decimals betray the inch display


def test_unplug_is_a_link_error_and_the_cable_is_then_not_found(cable):
    endpoint, gauge = cable
    gauge.read()
    endpoint.set_fault(Fault.UNPLUG)
    with pytest.raises(LinkError, match=f"{WHERE}: USB link lost.*unplugged") as error:
        gauge.read()
    assert "\n" not in str(error.value)
    with pytest.raises(LinkError, match=f"{WHERE}: no USB device 0fe7:4001.*plugged in"):
        open_indicator("usb-itn", endpoint.port, unit="mm", where=WHERE)


def test_no_cable_on_this_pc_is_one_line():
    with pytest.raises(LinkError, match="gauge U: ") as error:
        open_indicator("usb-itn", "usb", unit="mm", where="gauge U")
    assert "\n" not in str(error.value)


def test_without_pyusb_the_message_says_how_to_install_it():
    code = (
        "import sys; sys.modules['usb'] = None\n"
        "from ogacq_drivers.indicators import open_indicator\n"
        "from ogacq_drivers.errors import LinkError\n"
        "try:\n"
        "    open_indicator('usb-itn', 'usb', unit='mm', where='gauge U')\n"
        "except LinkError as e:\n"
        "    print(e)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip().startswith("gauge U: USB cables need pyusb")
    assert "pip install 'ogacq[usb]'" in out.stdout


# Whole messages and what they mean (None: a status, never a number).
KNOWN = {b"01A+0000.123\r": 0.123, b"01A-0012.345\r": -12.345, b"918\r": None, b"911\r": None,
         b"1SIM-ITN\r": None}
_whole = st.sampled_from(sorted(KNOWN))
_cut = _whole.flatmap(lambda f: st.integers(0, len(f) - 1).map(lambda i: f[:i]))
_replies = st.lists(st.one_of(st.binary(max_size=16), _whole, _cut), min_size=1, max_size=4)


@pytest.fixture(scope="module")
def fuzz_cable() -> Iterator[tuple[UsbItnEndpoint, UsbItn]]:
    endpoint = UsbItnEndpoint(lambda: 0.0).start()
    gauge = open_indicator("usb-itn", endpoint.port, unit="mm", where="fuzz", timeout_s=0.1)
    gauge.busy_retry_delay_s = 0.2  # longer than the deadline: a busy reply is not retried
    yield endpoint, gauge
    gauge.close()
    endpoint.close()


@settings(max_examples=30, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(chunks=_replies)
def test_garbage_on_the_interrupt_endpoint_never_gives_a_wrong_number(fuzz_cable, chunks):
    endpoint, gauge = fuzz_cable
    raw = b"".join(chunks)
    endpoint.answer_next_with(raw)
    try:
        reading = gauge.read()
    except DriverError as exc:
        assert "fuzz" in str(exc)
    else:
        assert reading.frame in raw  # a number comes only from a whole 01A value message
        if reading.frame in KNOWN:
            assert reading.value_mm == KNOWN[reading.frame]
        else:  # pieces that join into a whole one (b"01A+0000." + b"911\r"): it is one
            assert re.fullmatch(rb"01A[+-][0-9]{4}\.[0-9]{3}\r", reading.frame), reading.frame
            assert reading.value_mm == float(reading.frame[3:-1])


@pytest.mark.parametrize(
    ("raw", "kind"),
    [  # pytuyo: the first character says what a message is (0 data, 1 info, 9 status)
        (b"01A+0000.123\r", "0"),
        (b"1SIM-ITN V1.0\r", "1"),
        (b"918\r", "9"),  # the second open script: sent "until data is available again"
    ],
)
def test_messages_are_classified_by_their_first_character(raw: bytes, kind: str):
    assert classify(raw) == Message(kind, raw)


@pytest.mark.parametrize("raw", [b"21A+0000.123\r", b"01A+0000.123", b"", b"\r"])
def test_other_messages_are_frame_errors(raw: bytes):
    with pytest.raises(FrameError):
        classify(raw, where="itn")


def test_a_reply_for_another_channel_is_refused(cable):
    """A USB-ITN carries one gauge: its replies are channel 1, always (pytuyo: the first
    two characters of a value are "always 1A"; QM-Height manual 99MAF600B, 6.2.2 USB
    data output: D2 channel No. "1" (fixed)). A reply naming another channel is not
    this cable's gauge answering, so it is refused, not read."""
    endpoint, gauge = cable
    endpoint.answer_next_with(b"02A+0001.233\r")
    with pytest.raises(FrameError, match=f"{WHERE}: .*channel 2"):
        gauge.read()
    assert gauge.read().value_mm == 1.233  # the next reply is the cable's own again
    with pytest.raises(FrameError, match="channel 2"):
        CODEC.decode(b"02A+0001.233\r")
