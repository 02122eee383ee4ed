"""Line errors on a real pseudo-terminal: a byte the UART received with a parity or
framing error must never pass as a character of a frame.

termios(3), "INPCK: enable input parity checking"; "IGNPAR: ignore framing errors and
parity errors"; "PARMRK: ... If neither IGNPAR nor PARMRK is set, read a character
with a parity error or framing error as \\0". Linux's n_tty applies that only when
INPCK is set (n_tty_receive_parity_error), and its UART drivers report framing and
parity errors only with INPCK (8250: read_status_mask). pyserial 3.5 clears INPCK
every time it configures a port (serialposix.Serial._reconfigure_port), so without
the driver setting it back, the Sylvac line's 7E2 parity (Opto-RS manual, Bowers /
Sylvac Opto instruments manual p. 12: "4800 baudrate, even parity, 7 data bits,
2 stop bits") guarded nothing: a digit with one bit flipped was read as another digit.

A pty has no UART, so what the tests check is what the driver controls: the termios
flags the kernel reads on the port it opened, and the refusal, naming the line, of
the NUL such a byte is read as.
"""

from __future__ import annotations

import os
import termios
import threading
import time
import tty
from collections.abc import Iterator
from typing import Any

import pytest

from ogacq_drivers.errors import FrameError
from ogacq_drivers.indicators import open_indicator

SERIAL_PROTOCOLS = ("mitutoyo-01a", "digimatic", "uwave", "sylvac")


@pytest.fixture
def pty_pair() -> Iterator[tuple[int, str]]:
    master, slave = os.openpty()
    tty.setraw(slave)
    path = os.ttyname(slave)
    try:
        yield master, path
    finally:
        os.close(master)
        os.close(slave)


def _iflag(link: Any) -> int:
    return termios.tcgetattr(link.fd)[0]


@pytest.mark.parametrize("protocol", SERIAL_PROTOCOLS)
def test_the_driver_has_the_kernel_flag_bytes_with_line_errors(
    pty_pair: tuple[int, str], protocol: str
) -> None:
    _master, path = pty_pair
    gauge: Any = open_indicator(protocol, path, unit="mm", where=f"{protocol} on {path}")
    try:
        iflag = _iflag(gauge.link)
        assert iflag & termios.INPCK, "INPCK clear: parity and framing errors go unseen"
        assert not iflag & (termios.IGNPAR | termios.PARMRK), "errors must read as NUL"
        # pyserial clears INPCK again whenever it reconfigures the port (here: a
        # timeout set by someone else); the next request's flush sets it back.
        gauge.link.timeout = 0.05
        gauge.flush_input()
        assert _iflag(gauge.link) & termios.INPCK
    finally:
        gauge.close()


# The bytes a 7E2 port reads for "+12.345\r" when the UART flags the "2" (parity
# error): NUL in its place (termios(3), above). Without the flag the "2" could as well
# have been any digit one bit away ("0", "3", "6").
@pytest.mark.parametrize(("protocol", "frame"), [
    ("sylvac", b"+1\x00.345\r"),
    ("mitutoyo-01a", b"01A+0\x0000.123\r"),
])
def test_a_byte_read_as_nul_is_refused_as_a_line_error(
    pty_pair: tuple[int, str], protocol: str, frame: bytes
) -> None:
    master, path = pty_pair
    gauge = open_indicator(protocol, path, unit="mm", where=f"gauge 3 ({path})", timeout_s=2)
    try:
        with pytest.raises(FrameError) as caught:
            _request_then_answer(gauge, master, frame)
        message = str(caught.value)
        assert "parity or framing error" in message and "gauge 3" in message
    finally:
        gauge.close()


def _request_then_answer(gauge: Any, master: int, frame: bytes) -> None:
    """Answer the driver's request on the pty's other side with ``frame``."""

    def answer() -> None:
        deadline = time.monotonic() + 2
        seen = b""
        while b"\r" not in seen and time.monotonic() < deadline:
            try:
                seen += os.read(master, 64)
            except BlockingIOError:
                time.sleep(0.005)
        os.write(master, frame)

    os.set_blocking(master, False)
    helper = threading.Thread(target=answer)
    helper.start()
    try:
        gauge.read()
    finally:
        helper.join()


@pytest.mark.parametrize("code", ["01", "03", "04", "05"])
def test_uwave_reading_after_a_status_of_a_lost_reading_is_taken(
    pty_pair: tuple[int, str], code: str, caplog: pytest.LogCaptureFixture
) -> None:
    """U-WAVE-R statuses 01, 03, 04, 05 say a reading did not arrive (99MAL216A 6.1, as
    drivers/indicators/uwave.py quotes it): the data frame the receiver pushes after
    one is a new reading, taken; the status is logged, not a stop."""
    master, path = pty_pair
    gauge: Any = open_indicator("uwave", path, unit="mm", where=f"uwave on {path}")
    try:
        os.write(master, b"ST10000FFFFFFFFFF" + code.encode() + b"\rDT10000+00000011.88M\r")
        reading = gauge.read(timeout_s=30.0)  # bounded; both frames are already written
    finally:
        gauge.close()
    assert reading.value_mm == pytest.approx(11.88)
    assert f"uwave on {path}" in caplog.text and "waiting for its next reading" in caplog.text
