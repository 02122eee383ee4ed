"""Indicator drivers on a scripted link (the exact exchange on the wire), the
stability rule, link opening and the backend table."""

from __future__ import annotations

import socket
import subprocess
import sys
import time
from collections.abc import Iterable
from typing import Self

import pytest
from hypothesis import given, settings
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
from ogacq_drivers.indicators import BACKENDS, driver_class, open_indicator
from ogacq_drivers.indicators.base import Indicator, Reading, read_stable
from ogacq_drivers.indicators.digimatic import DigimaticBridge
from ogacq_drivers.indicators.mitutoyo_01a import Mitutoyo01A
from ogacq_drivers.indicators.sylvac import SylvacOptoRS
from ogacq_drivers.indicators.sylvac_simplex import SylvacSimplex
from ogacq_drivers.indicators.uwave import UWaveReceiver
from ogacq_drivers.link import LinkSettings, open_link


class ScriptedLink:
    """A serial.Serial stand-in that asserts the exact exchange (pymeasure's
    ``expected_protocol`` habit): each write must be the next expected request,
    and its scripted reply becomes readable. ``pushed`` bytes are readable from
    the start (a free-running device).

    Used as a context manager, its exit asserts that every scripted request was sent
    and every byte read but ``unread`` (what the device pushed beyond what the test
    reads; None: not judged, for random input), unless the block raised: a driver
    that stops short of the script fails the test that ignores it."""

    def __init__(
        self,
        exchanges: Iterable[tuple[bytes, bytes]] = (),
        *,
        pushed: bytes = b"",
        unread: bytes | None = b"",
    ) -> None:
        self.script = list(exchanges)
        self.rx = bytearray(pushed)
        self.unread = unread
        self.timeout: float | None = 0.01
        self.dtr = False
        self.rts = True
        self.closed = False

    def __enter__(self) -> Self:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, *_: object) -> None:
        if exc_type is None:
            self.assert_done()

    def write(self, data: bytes) -> int:
        assert self.script, f"unexpected write {data!r}: the script is finished"
        expected, reply = self.script.pop(0)
        assert data == expected, f"sent {data!r}, expected {expected!r}"
        self.rx += reply
        return len(data)

    def flush(self) -> None:
        pass

    @property
    def in_waiting(self) -> int:
        return len(self.rx)

    def read(self, size: int = 1) -> bytes:
        chunk = bytes(self.rx[:size])
        del self.rx[:size]
        return chunk

    def reset_input_buffer(self) -> None:
        self.rx.clear()

    def close(self) -> None:
        self.closed = True

    def assert_done(self) -> None:
        assert not self.script, f"requests never sent: {self.script}"
        if self.unread is not None:
            assert bytes(self.rx) == self.unread, \
                f"bytes left unread: {bytes(self.rx)!r}, expected {self.unread!r}"


def _01a(link: ScriptedLink, **options) -> Mitutoyo01A:
    options.setdefault("unit", "mm")
    return Mitutoyo01A(link, where="dial A", timeout_s=0.05, **options)  # type: ignore[arg-type]


# ---------------------------------------------------------------------- 01A


def test_01a_exchange_on_the_wire():
    with ScriptedLink([(b"1\r", b"01A+0000.123\r")]) as link:
        reading = _01a(link).read()
        assert reading.value_mm == 0.123
        assert reading.frame == b"01A+0000.123\r"
        assert (reading.channel, reading.unit, reading.where) == ("1", "mm", "dial A")
        assert abs(reading.time_s - time.time()) < 5


def test_01a_multiplexer_channels_share_one_link():
    with ScriptedLink([(b"2\r", b"02A-0012.345\r"), (b"C\r", b"0CA+0001.000\r")]) as link:
        assert _01a(link, channel="2").read().value_mm == -12.345
        assert _01a(link, channel="C").read().value_mm == 1.0


def test_01a_reply_from_another_channel_is_refused():
    refused = pytest.raises(FrameError, match="channel 1, asked channel 2")
    with ScriptedLink([(b"2\r", b"01A+0000.123\r")]) as link, refused:
        _01a(link, channel="2").read()


def test_01a_inch_gauge_configured_inch_is_converted():
    with ScriptedLink([(b"1\r", b"01A+000.1234\r")]) as link:
        reading = _01a(link, unit="inch").read()
        assert reading.value_mm == 3.13436 and reading.unit == "inch"


@pytest.mark.parametrize(
    ("unit", "frame"),
    [("mm", b"01A+000.1234\r"), ("mm", b"01A-001.2340\r"), ("inch", b"01A+0000.123\r")],
)
def test_01a_layout_contradicting_the_unit_raises_unit_error(unit: str, frame: bytes):
    with ScriptedLink([(b"1\r", frame)]) as link, pytest.raises(UnitError, match="dial A"):
        _01a(link, unit=unit).read()


def test_01a_fine_mm_gauge_needs_its_decimals_spelled_out():
    with ScriptedLink([(b"1\r", b"01A-001.2340\r")]) as link:
        assert _01a(link, decimals=4).read().value_mm == -1.234


def test_01a_busy_is_retried_then_answered():
    busy_twice = [(b"1\r", b"918\r"), (b"1\r", b"918\r"), (b"1\r", b"01A+0000.123\r")]
    with ScriptedLink(busy_twice) as link:
        gauge = Mitutoyo01A(link, where="dial A", unit="mm", busy_retry_delay_s=0.001)  # type: ignore[arg-type]
        assert gauge.read().value_mm == 0.123


def test_01a_busy_beyond_the_retries_raises_device_busy():
    with ScriptedLink([(b"1\r", b"918\r")] * 4) as link:
        gauge = Mitutoyo01A(
            link,  # type: ignore[arg-type]
            where="dial A",
            unit="mm",
            busy_retries=3,
            busy_retry_delay_s=0.001,
        )
        with pytest.raises(DeviceBusy, match="dial A") as busy:
            gauge.read()
        assert busy.value.code == "918"
        # the exit asserts exactly 1 + 3 requests


def test_01a_error_code_is_a_device_fault_not_a_number():
    with ScriptedLink([(b"1\r", b"911\r")]) as link:
        with pytest.raises(DeviceFault, match="dial A.*911") as fault:
            _01a(link).read()
        assert fault.value.code == "911"


def test_01a_device_info():
    with ScriptedLink([(b"V\r", b"USB-ITN  V1.02\r")]) as link:
        assert _01a(link).device_info() == "USB-ITN  V1.02"


def test_01a_stale_input_is_flushed_before_the_request():
    stale = b"01A+0001.000\r01A+0001.000\r"
    with ScriptedLink([(b"1\r", b"01A+0002.000\r")], pushed=stale) as link:
        assert _01a(link).read().value_mm == 2.0


def test_silence_is_a_timeout_naming_the_gauge():
    with ScriptedLink([(b"1\r", b"")]) as link:
        start = time.monotonic()
        with pytest.raises(DeviceTimeout, match="dial A.*no reply"):
            _01a(link).read()
        assert time.monotonic() - start < 0.5


def test_partial_frame_at_the_deadline_is_a_timeout_showing_the_bytes():
    timeout = pytest.raises(DeviceTimeout, match=r"incomplete frame.*01A\+00")
    with ScriptedLink([(b"1\r", b"01A+00")]) as link, timeout:
        _01a(link).read()


def test_endless_bytes_without_terminator_are_a_frame_error():
    with ScriptedLink([(b"1\r", b"0" * 200)]) as link, pytest.raises(FrameError,
                                                                   match="no terminator"):
        _01a(link).read()


# ---------------------------------------------------------------- Digimatic


def test_digimatic_polled_exchange():
    with ScriptedLink([(b"\r", b"FFFF000123330\r\n")]) as link:
        gauge = DigimaticBridge(link, where="dg", unit="mm")  # type: ignore[arg-type]
        reading = gauge.read()
        assert reading.value_mm == 1.233 and reading.frame == b"FFFF000123330\r"


def test_digimatic_streaming_skips_the_cut_frame_and_reads_in_order():
    with ScriptedLink(pushed=b"0012330\r\nFFFF000123330\r\nFFFF000123430\r\n") as link:
        gauge = DigimaticBridge(link, where="dg", unit="mm", mode="streaming")  # type: ignore[arg-type]
        assert [gauge.read().value_mm, gauge.read().value_mm] == [1.233, 1.234]


def test_digimatic_garbled_frame_in_a_stream_is_reported():
    with ScriptedLink(pushed=b"FFFF000123330\r\nFFFF0001#3330\r\n") as link:
        gauge = DigimaticBridge(link, where="dg", unit="mm", mode="streaming")  # type: ignore[arg-type]
        gauge.read()
        with pytest.raises(FrameError, match="dg"):
            gauge.read()


def test_digimatic_inch_frames_are_converted_and_logged(caplog: pytest.LogCaptureFixture):
    with ScriptedLink([(b"\r", b"FFFF000485558\r\n")]) as link:
        gauge = DigimaticBridge(link, where="dg", unit="mm")  # type: ignore[arg-type]
        with caplog.at_level("INFO"):
            reading = gauge.read()
        assert reading.value_mm == pytest.approx(1.23317) and reading.unit == "inch"
        assert "nibble 8" in caplog.text and "configured mm" in caplog.text


# ------------------------------------------------------------------- U-WAVE


def test_uwave_filters_transmitters_and_skips_battery_warnings(caplog: pytest.LogCaptureFixture):
    frames = b"DT10001+0000001.000M\rST10002FFFFFFFFFF00\rDT10002+0000002.000M\r"
    with ScriptedLink(pushed=frames) as link:
        gauge = UWaveReceiver(link, where="uw", unit="mm", channel="02")  # type: ignore[arg-type]
        reading = gauge.read()
        assert (reading.value_mm, reading.channel) == (2.0, "0002")
        assert "battery low" in caplog.text


def test_uwave_status_of_a_lost_reading_is_named_when_no_reading_follows():
    with ScriptedLink(pushed=b"ST10000FFFFFFFFFF04\r") as link:
        gauge = UWaveReceiver(link, where="uw", unit="mm", timeout_s=0.05)  # type: ignore[arg-type]
        with pytest.raises(DeviceFault, match="uw.*disconnected") as fault:
            gauge.read()
        assert fault.value.code == "04"


@pytest.mark.parametrize("code", ["02", "50", "51", "99", "07"])
def test_uwave_status_of_the_instrument_or_receiver_stops_the_reading(code: str):
    frames = b"ST100001234567890" + code.encode() + b"\rDT10000+0000001.000M\r"
    with ScriptedLink(pushed=frames) as link:
        gauge = UWaveReceiver(link, where="uw", unit="mm", timeout_s=0.05)  # type: ignore[arg-type]
        with pytest.raises(DeviceFault, match="uw.*id 1234567890") as fault:
            gauge.read()
        assert fault.value.code == code


def test_uwave_unit_zero_takes_the_configured_unit_and_checks_its_decimals():
    with ScriptedLink(pushed=b"DT10000+000001.50000\rDT10000+0000001.2340\r") as link:
        gauge = UWaveReceiver(link, where="uw", unit="inch", timeout_s=0.05)  # type: ignore[arg-type]
        reading = gauge.read()
        assert (reading.value_mm, reading.unit) == (pytest.approx(38.1), "inch")
        with pytest.raises(UnitError, match="uw"):
            gauge.read()  # three decimals: an mm layout on a gauge set up in inch


# ------------------------------------------------------------------- Sylvac


def test_sylvac_powers_the_cable_and_reads():
    with ScriptedLink([(b"?\r", b"+12.345\r")]) as link:
        gauge = SylvacOptoRS(link, where="sy", unit="mm")  # type: ignore[arg-type]
        assert (link.dtr, link.rts) == (True, False)
        assert gauge.read().value_mm == 12.345


def test_sylvac_skips_an_echoed_request():
    with ScriptedLink([(b"?\r", b"?\r-0.005\r")]) as link:
        assert SylvacOptoRS(link, where="sy", unit="mm").read().value_mm == -0.005  # type: ignore[arg-type]


def test_sylvac_skips_the_power_on_identification(caplog: pytest.LogCaptureFixture):
    with ScriptedLink([(b"?\r", b"SY235.1\r+0.250\r")]) as link:
        with caplog.at_level("INFO"):
            assert SylvacOptoRS(link, where="sy", unit="mm").read().value_mm == 0.25  # type: ignore[arg-type]
        assert "SY235.1" in caplog.text


def test_sylvac_error_and_unit_mismatch():
    with ScriptedLink([(b"?\r", b"ERR3\r"), (b"?\r", b"+0.04855\r")]) as link:
        gauge = SylvacOptoRS(link, where="sy", unit="mm")  # type: ignore[arg-type]
        with pytest.raises(DeviceFault, match="sy.*range"):
            gauge.read()
        with pytest.raises(UnitError, match="sy"):
            gauge.read()


# ----------------------------------------------------------- random input


class DtrPulsedLink(ScriptedLink):
    """A simplex instrument's line: DTR back high after a low pulse releases ``answer``."""

    def __init__(self, answer: bytes, *, unread: bytes | None = b"") -> None:
        self.answer = answer
        self._dtr = True
        super().__init__(unread=unread)

    @property
    def dtr(self) -> bool:
        return self._dtr

    @dtr.setter
    def dtr(self, level: bool) -> None:
        if level and not self._dtr:
            self.rx += self.answer
        self._dtr = level


def test_sylvac_simplex_pulses_dtr_and_powers_from_rts():
    with DtrPulsedLink(b"SY235.1\r+0.125\r") as link:
        gauge = SylvacSimplex(link, where="sx", unit="mm")  # type: ignore[arg-type]
        assert (link.dtr, link.rts) == (True, True)
        start = time.monotonic()
        assert gauge.read().value_mm == 0.125
        assert time.monotonic() - start >= 0.110
        assert link.dtr is True  # back at rest


# Whole frames of every protocol, and what each means in mm.
KNOWN_FRAMES = {
    b"01A+0000.123\r": 0.123,
    b"FFFF000123330\r\n": 1.233,
    b"DT10000+00000011.88M\r": 11.88,
    b"+1.233\r": 1.233,
    b"918\r": None,
    b"ERR3\r": None,
    b"ST10000FFFFFFFFFF04\r": None,
}
_whole = st.sampled_from(sorted(KNOWN_FRAMES))
_cut = _whole.flatmap(lambda f: st.integers(0, len(f) - 1).map(lambda i: f[:i]))
_chunks = st.lists(st.one_of(st.binary(max_size=20), _whole, _cut), max_size=5)


@pytest.mark.parametrize("protocol", sorted(p for p, b in BACKENDS.items() if b.serial))
@settings(max_examples=40, deadline=None)
@given(chunks=_chunks)
def test_drivers_fed_random_and_cut_frames_never_give_a_wrong_number(
    protocol: str, chunks: list[bytes]
):
    data = b"".join(chunks)
    # random input: what is left unread is not judged, only that nothing is misread
    simplex = protocol == "sylvac-simplex"
    with (DtrPulsedLink(data, unread=None) if simplex
          else ScriptedLink(pushed=data, unread=None)) as link:
        link.write = lambda request: link.rx.extend(data) or len(request)  # type: ignore[method-assign]
        options = {"mode": "streaming"} if protocol == "digimatic" else {}
        gauge = driver_class(protocol)(link, where="fuzz", unit="mm", timeout_s=0.002, **options)
        gauge.request_pulse_s = 0.0  # the simplex pulse length is not what this test is about
        for _ in range(3):
            try:
                reading = gauge.read()
            except DriverError as exc:
                assert "fuzz" in str(exc)
            else:
                assert reading.frame in data
                whole = next((f for f in KNOWN_FRAMES if f.startswith(reading.frame)), None)
                if whole is not None:
                    assert reading.value_mm == KNOWN_FRAMES[whole]


# ---------------------------------------------------------------- stability


class FakeIndicator:
    """An Indicator giving scripted values (floats) or raising scripted errors."""

    def __init__(self, script: list[float | DriverError], where: str = "fake gauge") -> None:
        self.script = list(script)
        self.where = where
        self.flushes = 0

    def flush_input(self) -> None:
        self.flushes += 1

    def close(self) -> None:
        pass

    def read(self, timeout_s: float | None = None) -> Reading:
        if not self.script:
            raise DeviceTimeout("no reply before the deadline", where=self.where)
        item = self.script.pop(0)
        if isinstance(item, DriverError):
            raise item
        return Reading(value_mm=item, frame=b"", time_s=time.time(), where=self.where)


def test_fake_indicator_meets_the_protocol():
    assert isinstance(FakeIndicator([]), Indicator)
    with ScriptedLink() as link:
        assert isinstance(_01a(link), Indicator)


def test_read_stable_waits_for_n_consecutive_values_within_tolerance():
    gauge = FakeIndicator([1.0, 1.5, 1.233, 1.235, 1.234])
    stable = read_stable(gauge, n=3, tolerance_mm=0.002, timeout_s=1)
    assert gauge.flushes == 1
    assert stable.value_mm == pytest.approx(1.234)
    assert stable.spread_mm == pytest.approx(0.002)
    assert [r.value_mm for r in stable.readings] == [1.233, 1.235, 1.234]
    assert stable.where == "fake gauge"


def test_read_stable_restarts_the_run_after_a_garbled_frame():
    garbled = FrameError("not a 01A reply", where="fake gauge", frame=b"01A+00#0.123\r")
    gauge = FakeIndicator([1.0, 1.0, garbled, 1.0, 1.0, 1.0])
    stable = read_stable(gauge, n=3, tolerance_mm=0.001, timeout_s=1)
    assert len(stable.readings) == 3 and not gauge.script


def test_read_stable_that_never_settles_names_the_gauge():
    gauge = FakeIndicator([1.0, 2.0, 3.0, 4.0])
    with pytest.raises(DeviceTimeout, match="fake gauge: readings did not settle.*4 readings"):
        read_stable(gauge, n=3, tolerance_mm=0.001, timeout_s=1)


def test_read_stable_passes_on_a_silent_gauge_and_device_faults():
    with pytest.raises(DeviceTimeout, match="no reply"):
        read_stable(FakeIndicator([]), n=3)
    fault = DeviceFault("error 911", code="911", where="fake gauge")
    with pytest.raises(DeviceFault):
        read_stable(FakeIndicator([1.0, fault, 1.0, 1.0]), n=3)


# --------------------------------------------------------------------- link


def test_missing_device_is_a_link_error_naming_the_port():
    with pytest.raises(LinkError, match="/dev/ttyUSB-ogacq-missing.*plugged in"):
        open_link("/dev/ttyUSB-ogacq-missing")


def test_com_port_name_on_this_system_is_a_link_error_naming_it():
    with pytest.raises(LinkError, match="COM3"):
        open_indicator("mitutoyo-01a", "COM3", unit="mm", where="dial A")


def test_refused_socket_is_a_link_error_naming_the_url():
    with socket.socket() as probe:  # a free port nobody listens on
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    with pytest.raises(LinkError, match=rf"dial A: cannot open socket://127.0.0.1:{port}.*refused"):
        open_indicator("sylvac", f"socket://127.0.0.1:{port}", unit="mm", where="dial A")


def test_bad_settings_are_a_link_error():
    with pytest.raises(LinkError, match="loop://"):
        open_link("loop://", LinkSettings(parity="X"))
    with pytest.raises(LinkError, match="loop://"):
        open_link("loop://", LinkSettings(bytesize=9))


def test_loop_url_opens_with_the_settings():
    link = open_link("loop://", LinkSettings(baudrate=4800, bytesize=7, parity="E", stopbits=2))
    try:
        assert (link.baudrate, link.bytesize, link.parity, link.stopbits) == (4800, 7, "E", 2)
        link.write(b"x")
        assert link.read(1) == b"x"
    finally:
        link.close()
    assert LinkSettings(bytesize=7, parity="E", stopbits=2).bits_per_byte == 11
    assert LinkSettings().bits_per_byte == 10


# -------------------------------------------------------------- the table


def test_unknown_protocol_lists_the_known_ones():
    with pytest.raises(DriverError, match="unknown indicator protocol 'mitutoyo'.*sylvac"):
        open_indicator("mitutoyo", "loop://", unit="mm")


def test_backends_are_imported_lazily():
    code = (
        "import sys, ogacq_drivers.indicators as d;"
        "assert not any(m in sys.modules for m in "
        "('ogacq_drivers.indicators.sylvac', 'ogacq_drivers.indicators.uwave',"
        " 'ogacq_drivers.indicators.digimatic', 'ogacq_drivers.indicators.mitutoyo_01a'));"
        "d.driver_class('sylvac'); assert 'ogacq_drivers.indicators.sylvac' in sys.modules"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_factory_closes_the_link_when_the_driver_refuses_its_configuration():
    with pytest.raises(UnitError):
        open_indicator("mitutoyo-01a", "loop://", unit="furlong")


@pytest.mark.parametrize(
    ("protocol", "options"),
    [
        ("mitutoyo-01a", {"channel": "12"}),
        ("uwave", {"channel": "1"}),
        ("digimatic", {"mode": "burst"}),
    ],
)
def test_bad_configuration_is_a_driver_error_naming_the_gauge(protocol: str, options: dict):
    with pytest.raises(DriverError, match="gauge Q"):
        open_indicator(protocol, "loop://", unit="mm", where="gauge Q", **options)


def test_factory_reuses_a_given_link_without_owning_it():
    with ScriptedLink([(b"3\r", b"03A+0000.500\r")]) as link:
        gauge = open_indicator("mitutoyo-01a", "unused", unit="mm", channel="3", link=link)  # type: ignore[arg-type]
        assert gauge.read().value_mm == 0.5
        gauge.close()  # type: ignore[attr-defined]
        assert not link.closed


def test_scripted_link_names_what_the_driver_left_of_the_script():
    """The link's exit is the check every test above relies on: a request never sent
    or a byte never read fails the test, unless the block raised its own error."""
    twice = [(b"1\r", b"01A+0000.123\r"), (b"1\r", b"01A+0000.124\r")]
    with pytest.raises(AssertionError, match="requests never sent"), ScriptedLink(twice) as link:
        _01a(link).read()
    with pytest.raises(AssertionError, match="bytes left unread"), \
            ScriptedLink(pushed=b"01A+0000.123\r"):
        pass
    # the block's own error, not the script's
    wrong_channel = [(b"2\r", b"01A+0000.123\r"), (b"2\r", b"")]
    with pytest.raises(FrameError), ScriptedLink(wrong_channel) as link:
        _01a(link, channel="2").read()
