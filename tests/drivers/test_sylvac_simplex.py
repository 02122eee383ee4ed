"""The Sylvac Opto-RS simplex cable end to end: the real driver against the
simulated instrument over RFC 2217 (pyserial's client and port manager), the
one serial transport here that carries DTR and RTS."""

from __future__ import annotations

import logging
import time
from collections.abc import Iterator

import pytest

from ogacq_drivers.errors import DeviceFault, DeviceTimeout, FrameError, LinkError
from ogacq_drivers.indicators import open_indicator, read_stable
from ogacq_drivers.indicators.sylvac_simplex import REQUEST_PULSE_S
from ogacq_drivers.sim.gauges import Fault, GaugeEndpoint

WHERE = "simplex-3"


@pytest.fixture
def simplex() -> Iterator[tuple[GaugeEndpoint, object]]:
    endpoint = GaugeEndpoint("sylvac-simplex", lambda: 1.2334, baud=57600).start()
    gauge = open_indicator("sylvac-simplex", endpoint.port, unit="mm", where=WHERE, timeout_s=3)
    yield endpoint, gauge
    gauge.close()
    endpoint.close()


def test_a_dtr_pulse_asks_for_one_value(simplex):
    endpoint, gauge = simplex
    assert endpoint.port.startswith("rfc2217://")
    link = gauge.link
    assert (link.baudrate, link.bytesize, link.parity, link.stopbits) == (4800, 7, "E", 2)
    assert (link.rts, link.dtr) == (True, True)  # powered, resting
    before = endpoint.requests_received
    start = time.monotonic()
    reading = gauge.read()
    assert time.monotonic() - start >= REQUEST_PULSE_S >= 0.110  # the manual's minimum
    assert (reading.value_mm, reading.frame) == (1.233, b"+1.233\r")
    assert endpoint.requests_received - before == 1
    assert read_stable(gauge, n=2, tolerance_mm=0.001, timeout_s=3).value_mm == 1.233


def test_a_pulse_shorter_than_the_minimum_is_no_request(simplex, monkeypatch):
    endpoint, gauge = simplex
    gauge.read()  # past the power-on identification
    before = endpoint.requests_received
    # The instrument's minimum raised to 5 s, so that "shorter" does not depend on how
    # busy this machine is; the 110 ms itself is checked by the request test above.
    monkeypatch.setattr("ogacq_drivers.sim.gauges._SIMPLEX_PULSE_S", 5.0)
    gauge.link.dtr = False
    gauge.link.dtr = True  # low for a round trip: the instrument must not answer
    time.sleep(0.05)
    assert endpoint.requests_received == before and gauge.link.in_waiting == 0


def test_the_power_on_identification_is_skipped(caplog: pytest.LogCaptureFixture):
    with GaugeEndpoint("sylvac-simplex", lambda: -0.5, baud=57600) as endpoint:
        gauge = open_indicator("sylvac-simplex", endpoint.port, unit="mm", where=WHERE)
        try:
            gauge.flush_input = lambda: None  # keep the line the instrument sent at power-on
            deadline = time.monotonic() + 2
            while gauge.link.in_waiting < len(b"SY235.1\r") and time.monotonic() < deadline:
                time.sleep(0.01)
            with caplog.at_level(logging.INFO):
                assert gauge.read().value_mm == -0.5
            assert "SY235.1" in caplog.text
        finally:
            gauge.close()


def test_faults_are_named_and_the_gauge_recovers(simplex):
    endpoint, gauge = simplex
    endpoint.set_fault(Fault.SILENCE)
    with pytest.raises(DeviceTimeout, match=WHERE):
        gauge.read(timeout_s=0.3)
    endpoint.clear_fault()
    endpoint.set_fault(Fault.GARBLED, count=1)
    with pytest.raises(FrameError, match=f"{WHERE}.*#"):
        gauge.read()
    endpoint.set_fault(Fault.ERROR, code="3", count=1)
    with pytest.raises(DeviceFault, match=f"{WHERE}.*range"):
        gauge.read()
    assert gauge.read().value_mm == 1.233


def test_unplug_is_a_link_error(simplex):
    endpoint, gauge = simplex
    endpoint.set_fault(Fault.UNPLUG)
    with pytest.raises(LinkError, match=WHERE):
        for _ in range(3):
            gauge.read(timeout_s=1)


def test_a_port_without_dtr_is_refused_in_one_line():
    with (
        GaugeEndpoint("sylvac", lambda: 1.0) as duplex_pty,  # a pty: no modem lines
        pytest.raises(LinkError, match=f"{WHERE}: .*no DTR/RTS lines") as error,
    ):
        open_indicator("sylvac-simplex", duplex_pty.port, unit="mm", where=WHERE)
    assert "\n" not in str(error.value)
