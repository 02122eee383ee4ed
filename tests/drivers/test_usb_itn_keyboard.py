"""The USB-ITN in keyboard mode end to end: the simulated cable writes kernel
input events into a device node with its sysfs ids; the driver finds it by
vendor/product id, reads and decodes the keys with the code used on hardware."""

from __future__ import annotations

import os
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ogacq_drivers.errors import DeviceTimeout, FrameError, LinkError, UnitError
from ogacq_drivers.indicators import open_indicator, read_stable
from ogacq_drivers.indicators.usb_itn_keyboard import UsbItnKeyboard, decode_line, key_events
from ogacq_drivers.input_link import EVENT, find_event_devices
from ogacq_drivers.sim.gauges import Fault
from ogacq_drivers.sim.keyboard import KeyboardEndpoint

WHERE = "kbd-2"


@pytest.fixture
def cable() -> Iterator[tuple[KeyboardEndpoint, UsbItnKeyboard]]:
    values = {"mm": 1.2334}
    endpoint = KeyboardEndpoint(lambda: values["mm"]).start()
    endpoint.values = values  # type: ignore[attr-defined]
    gauge = open_indicator("usb-itn-keyboard", endpoint.port, unit="mm", where=WHERE,
                           timeout_s=3)
    yield endpoint, gauge
    gauge.close()
    endpoint.close()


def test_typed_value_and_enter_decode(cable):
    endpoint, gauge = cable
    endpoint.trigger()
    reading = gauge.read()
    assert (reading.value_mm, reading.frame, reading.unit) == (1.233, b"1.233\n", "mm")
    endpoint.values["mm"] = -12.3456
    endpoint.trigger()
    assert gauge.read().value_mm == -12.346


def test_found_by_vendor_and_product_id_never_another_keyboard(tmp_path: Path):
    with KeyboardEndpoint(lambda: 0.0) as cable, KeyboardEndpoint(
        lambda: 0.0, vendor_id=0x046D, product_id=0xC31C  # somebody's office keyboard
    ) as keyboard:
        root = Path(cable.port).parents[2]
        assert find_event_devices(0x0FE7, 0x4001, root) == [Path(cable.port)]
        with pytest.raises(LinkError, match=f"{WHERE}: .*046d:c31c, not a Mitutoyo USB-ITN"):
            open_indicator("usb-itn-keyboard", keyboard.port, unit="mm", where=WHERE)
    with pytest.raises(LinkError, match=f"{WHERE}: .*not an input event device"):
        open_indicator("usb-itn-keyboard", str(tmp_path / "dev/input/event9"), unit="mm",
                       where=WHERE)


def test_flush_drops_old_lines_and_a_line_cut_in_the_middle(cable):
    endpoint, gauge = cable
    endpoint.set_fault(Fault.STALE, count=3)  # three old lines waiting
    gauge.flush_input()
    endpoint.values["mm"] = 2.5
    endpoint.trigger()
    assert gauge.read().value_mm == 2.5
    # Half a line arrives before a flush, the rest after: never read as a number.
    records = b"".join(EVENT.pack(0, 0, 1, code, value) for code, value in key_events("1.233"))
    half = len(records) // 2 // EVENT.size * EVENT.size
    os.write(endpoint._fd, records[:half])
    gauge.flush_input()
    os.write(endpoint._fd, records[half:])
    endpoint.trigger()
    assert gauge.read().value_mm == 2.5  # "233" after the cut was skipped, not read


def test_read_stable_on_a_cable_pressed_periodically():
    values = {"mm": 0.25}
    with KeyboardEndpoint(lambda: values["mm"], period_s=0.02) as endpoint:
        gauge = open_indicator("usb-itn-keyboard", endpoint.port, unit="mm", where=WHERE)
        try:
            assert read_stable(gauge, n=3, tolerance_mm=0.001, timeout_s=3).value_mm == 0.25
            values["mm"] = -1.5
            time.sleep(0.1)  # lines keep coming while nobody reads: read_stable drops them
            stable = read_stable(gauge, n=3, tolerance_mm=0.001, timeout_s=3)
            assert [r.value_mm for r in stable.readings] == [-1.5] * 3
        finally:
            gauge.close()


def test_silence_garbage_inch_and_unplug_are_named(cable):
    endpoint, gauge = cable
    start = time.monotonic()
    with pytest.raises(DeviceTimeout, match=f"{WHERE}: no value typed"):
        gauge.read(timeout_s=0.1)
    assert time.monotonic() - start < 5
    endpoint.set_fault(Fault.GARBLED, count=1)
    endpoint.trigger()
    with pytest.raises(FrameError, match=f"{WHERE}: typed line is not a value"):
        gauge.read()
    endpoint.set_fault(Fault.INCH)
    endpoint.trigger()
    with pytest.raises(UnitError, match=f"{WHERE}.*inch"):
        gauge.read()
    endpoint.clear_fault()
    endpoint.trigger()
    endpoint.set_fault(Fault.UNPLUG)
    assert gauge.read().value_mm == 1.233  # what was typed before the cable went is kept
    with pytest.raises(LinkError, match=f"{WHERE}: .*unplugged") as error:
        gauge.read()
    assert "\n" not in str(error.value)


@pytest.mark.parametrize(
    ("line", "value", "decimals"),
    [("1.233", "1.233", 3), ("-0.0050", "-0.0050", 4), ("+12.5", "12.5", 1), ("7", "7.0", 0)],
)
def test_line_grammar(line: str, value: str, decimals: int):
    decoded = decode_line(line)
    assert (str(decoded[0]), decoded[1]) == (value, decimals)


@pytest.mark.parametrize("line", ["", "1.2.3", "1,233", "12-3", "?1.2", "."])
def test_line_grammar_refuses(line: str):
    with pytest.raises(FrameError):
        decode_line(line)


_values = st.decimals(min_value=-99, max_value=99, places=3, allow_nan=False)
_lines = st.lists(st.tuples(_values, st.none() | st.integers(0, 8), st.sampled_from([30, 57, 51])),
                  min_size=1, max_size=4)


@settings(max_examples=25, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(lines=_lines)
def test_a_stray_key_makes_a_line_garbage_never_another_number(cable, lines):
    """Typed values with stray keys (A, space, comma) inserted: a line with one is
    refused, a clean line reads exactly its value."""
    endpoint, gauge = cable
    gauge.flush_input()
    records = bytearray()
    for value, where, stray in lines:
        text = f"{value:.3f}"
        events = key_events(text)
        if where is not None:
            at = 2 * min(where, len(text))  # before a character (press and release pairs)
            events[at:at] = [(stray, 1), (stray, 0)]
        records += b"".join(EVENT.pack(0, 0, 1, code, v) for code, v in events)
    os.write(endpoint._fd, bytes(records))
    for value, where, _ in lines:
        if where is None:
            assert gauge.read().value_mm == float(value)
        else:
            with pytest.raises(FrameError, match=WHERE):
                gauge.read()
