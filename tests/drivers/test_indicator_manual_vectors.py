"""The makers' example frames, each through the real driver on a real pseudo-terminal.

The far end of the pty is a script, not ogacq's simulator: it answers each request
with the bytes of a manual (or pushes them, for the free-running sources), so what is
checked is the driver and its codec against the document. Expected values are worked
out here from the manual's text with exact decimals, never by calling ogacq.

Sources (the section/page is next to each vector):
- QM = Mitutoyo QM-Height user's manual No. 99MAF600B: 6.2.1 "Digimatic data output"
  (p. 59) and 6.2.2 "USB data output specifications" (p. 67; the 01A reply: D1 "0",
  D2 channel "1", D3 "A", D4 sign, D5-D12 data with a floating decimal point, D13 CR).
- LSM = Mitutoyo LSM-6200 manual No. 99MBC095A, 6.2.1.5; PJ = measuring projector
  manual No. 99MBA043A, p. 6-12 (Digimatic frames).
- OPTO = Sylvac "User's manual for OPTO-RS cable connections", Bowers Group / Sylvac
  Opto instruments user manual, p. 12 (data format, errors, identification).
- UW = INSTRUMENTS.md's U-WAVE-R frame (M: public code) and the U-WAVE-R manual
  No. 99MAL216A, 6.1, as quoted in issue 12 (status frames).
"""

from __future__ import annotations

import math
import os
import threading
import time
import tty
from collections.abc import Iterator
from decimal import Decimal
from typing import Any

import pytest

from ogacq_drivers.errors import (
    DeviceBusy,
    DeviceFault,
    DeviceTimeout,
    DriverError,
    FrameError,
    UnitError,
)
from ogacq_drivers.indicators import open_indicator

INCH = Decimal("25.4")  # mm per inch, exact by definition


class ScriptedPty:
    """The far end of a real pty: each CR-terminated request (or, with
    ``answer_any_byte``, any byte) is answered with the next scripted reply."""

    def __init__(self, replies: list[bytes], *, answer_any_byte: bool = False) -> None:
        self.master, self._slave = os.openpty()
        tty.setraw(self._slave)
        os.set_blocking(self.master, False)
        self.port = os.ttyname(self._slave)
        self.replies = list(replies)
        self.requests: list[bytes] = []
        self._any = answer_any_byte
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, daemon=True)
        self._thread.start()

    def push(self, data: bytes) -> None:
        os.write(self.master, data)

    def _serve(self) -> None:
        pending = b""
        while not self._stop.is_set():
            try:
                pending += os.read(self.master, 64)
            except (BlockingIOError, OSError):
                time.sleep(0.002)
                continue
            while pending and (self._any or b"\r" in pending):
                if self._any:
                    request, pending = pending[:1], pending[1:]
                else:
                    head, _, pending = pending.partition(b"\r")
                    request = head + b"\r"
                self.requests.append(request)
                if self.replies:
                    os.write(self.master, self.replies.pop(0))

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2)
        for fd in (self.master, self._slave):
            os.close(fd)


@pytest.fixture
def far_end() -> Iterator[list[ScriptedPty]]:
    made: list[ScriptedPty] = []
    yield made
    for end in made:
        end.close()


def _gauge(far_end: list[ScriptedPty], protocol: str, replies: list[bytes], *, unit: str,
           **options: Any) -> tuple[Any, ScriptedPty]:
    end = ScriptedPty(replies, answer_any_byte=protocol == "digimatic")
    far_end.append(end)
    gauge = open_indicator(protocol, end.port, unit=unit, where=f"gauge A ({end.port})",
                           timeout_s=1.5, **options)
    return gauge, end


def _is_exactly(value_mm: float, expected: Decimal) -> bool:
    """The reading is the double nearest the exact value (one rounding, at the end);
    a zero is +0.0 (a record must not show "-0.0")."""
    return value_mm == float(expected) and (value_mm != 0 or math.copysign(1.0, value_mm) > 0)


# ----------------------------------------------------------------- values, as written
VALUES = [
    # protocol, configured unit, the frame as the manual prints it, its value in mm
    ("mitutoyo-01a", "mm", b"01A+0000.123\r", Decimal("0.123")),  # QM 6.2.2 p.67, mm 0.001
    ("mitutoyo-01a", "mm", b"01A+0000.125\r", Decimal("0.125")),  # QM 6.2.2 p.67, mm 0.005
    ("mitutoyo-01a", "inch", b"01A+00.12345\r",
     Decimal("0.12345") * INCH),  # QM 6.2.2 p.67, inch 0.00005
    ("mitutoyo-01a", "inch", b"01A+000.1234\r",
     Decimal("0.1234") * INCH),  # QM 6.2.2 p.67, inch 0.0001 (and 0.0002)
    ("mitutoyo-01a", "mm", b"01A-0000.000\r", Decimal(0)),  # QM 6.2.2 layout, "-" sign
    ("digimatic", "mm", b"FFFF000012330\r\n", Decimal("0.123")),  # QM 6.2.1 p.59
    ("digimatic", "mm", b"8F00000012330\r\n", Decimal("0.123")),  # QM 6.2.1 p.59 Digimatic 2
    ("digimatic", "mm", b"FFFF021076540\r\n", Decimal("21.0765")),  # LSM 6.2.1.5
    ("digimatic", "mm", b"FFFF801234530\r\n", Decimal("-12.345")),  # PJ 6-12
    # QM 6.2.1 p.59: unit "inch 1000" (bits, LSB first) = 1; sign "-: 8"; point 5. An
    # inch frame is converted from the unit it carries, whatever was set up.
    ("digimatic", "mm", b"FFFF801234551\r\n", -Decimal("0.12345") * INCH),
    ("digimatic", "mm", b"FFFF800000030\r\n", Decimal(0)),  # QM 6.2.1: sign 8 on zero
    ("sylvac", "mm", b"+12.345\r", Decimal("12.345")),  # OPTO p.12: sign, E, ".", F, CR
    ("sylvac", "mm", b" 0.000\r", Decimal(0)),  # OPTO p.12: the sign may be a space
    ("sylvac", "mm", b"-0.000\r", Decimal(0)),  # OPTO p.12: "-" on a zero
    ("sylvac", "inch", b"-0.04855\r", -Decimal("0.04855") * INCH),  # OPTO p.12, inch
    ("uwave", "mm", b"DT10000+00000011.88M\r", Decimal("11.88")),  # UW (INSTRUMENTS.md)
    ("uwave", "mm", b"DT10000+00000.04855I\r", Decimal("0.04855") * INCH),  # UW, unit I
]


@pytest.mark.parametrize(("protocol", "unit", "frame", "expected"), VALUES)
def test_the_manual_frames_read_to_their_values(
    far_end: list[ScriptedPty], protocol: str, unit: str, frame: bytes, expected: Decimal
) -> None:
    pushed = protocol == "uwave"
    gauge, end = _gauge(far_end, protocol, [] if pushed else [frame], unit=unit)
    if pushed:
        end.push(frame)
    reading = gauge.read()
    assert _is_exactly(reading.value_mm, expected), (reading.value_mm, expected)
    assert reading.frame.rstrip(b"\r\n") == frame.rstrip(b"\r\n")


# --------------------------------------------------------------------- refusals
REFUSED = [
    # A gauge switched to inch, read by a driver set up in mm (QM 6.2.2: the 01A reply
    # has no unit, only its decimals; OPTO p.12: "n depends on used unit and resolution").
    ("mitutoyo-01a", "mm", [b"01A+00.12345\r"], UnitError),
    ("mitutoyo-01a", "mm", [b"01A+000.1234\r"], UnitError),
    ("sylvac", "mm", [b"+0.48550\r"], UnitError),
    # A frame cut short, two run together, the wrong terminator (QM 6.2.2: D13 is CR).
    ("mitutoyo-01a", "mm", [b"01A+000.123\r"], FrameError),
    ("mitutoyo-01a", "mm", [b"01A+0000.12301A+0000.124\r"], FrameError),
    ("mitutoyo-01a", "mm", [b"01A+0000.123\n"], FrameError),
    ("digimatic", "mm", [b"FFFF00001233\r\n"], FrameError),  # 12 of QM's 13 nibbles
    ("digimatic", "mm", [b"FFFF0000123A0\r\n"], FrameError),  # a digit not BCD
    # Another channel answering (QM 6.2.2: D2 is the channel; we asked "1").
    ("mitutoyo-01a", "mm", [b"02A+0000.123\r"], FrameError),
    # Error frames: OPTO p.12 "ERR" number CR (3: exceeded measurement range); 01A
    # "911" (INSTRUMENTS.md, L: no maker source; pytuyo: "9" starts a status).
    ("sylvac", "mm", [b"ERR3\r"], DeviceFault),
    ("sylvac", "mm", [b"ERR0\r"], DeviceFault),
    ("mitutoyo-01a", "mm", [b"911\r"], DeviceFault),
    # Another protocol on the line: a Sylvac answer to an 01A request, an 01A reply to a
    # Digimatic poll.
    ("mitutoyo-01a", "mm", [b"+12.345\r"], FrameError),
    ("digimatic", "mm", [b"01A+0000.123\r"], FrameError),
    # A 7E2 gauge (OPTO p.12) read by an 8N1 port: the parity bit arrives as bit 7, so
    # "+12.345" CR is "+" 0xB1 0xB2 "." "3" 0xB4 "5" 0x8D, and no CR ever comes.
    ("mitutoyo-01a", "mm", [b"+\xb1\xb2.3\xb45\x8d"], DeviceTimeout),
]


@pytest.mark.parametrize(("protocol", "unit", "replies", "error"), REFUSED)
def test_frames_the_codec_cannot_vouch_for_are_refused(
    far_end: list[ScriptedPty], protocol: str, unit: str, replies: list[bytes],
    error: type[Exception],
) -> None:
    gauge, end = _gauge(far_end, protocol, replies, unit=unit)
    with pytest.raises(error) as caught:
        gauge.read()
    assert f"gauge A ({end.port})" in str(caught.value)


def test_silence_names_the_gauge_and_its_port(far_end: list[ScriptedPty]) -> None:
    gauge, end = _gauge(far_end, "sylvac", [], unit="mm")
    with pytest.raises(DeviceTimeout, match=f"gauge A \\({end.port}\\): no reply"):
        gauge.read(timeout_s=0.3)
    assert end.requests == [b"?\r"]  # OPTO p.13, duplex cable: data request "?" CR


def test_sylvac_identification_at_power_on_is_not_a_value(far_end: list[ScriptedPty]) -> None:
    # OPTO p.12: "SY" instrument "." OPT1 {"." OPT2} CR, sent when switched on.
    gauge, _ = _gauge(far_end, "sylvac", [b"SY235.1\r+1.000\r"], unit="mm")
    assert gauge.read().value_mm == 1.0


def test_uwave_frames_of_other_transmitters_and_status(far_end: list[ScriptedPty]) -> None:
    gauge, end = _gauge(far_end, "uwave", [], unit="mm", channel="0001")
    # UW: DT1 GG CC; another transmitter's value is not this gauge's.
    end.push(b"DT10002+00000022.22M\rDT10001+00000011.88M\r")
    reading = gauge.read()
    assert (reading.value_mm, reading.channel) == (11.88, "0001")
    # 99MAL216A 6.1 (issue 12): ST1 GG CC, 10-character id, status 04 disconnected.
    end.push(b"ST10001FFFFFFFFFF04\r")
    with pytest.raises(DeviceFault, match="04"):
        gauge.read()


def test_uwave_without_a_channel_refuses_once_two_transmitters_are_heard(
    far_end: list[ScriptedPty],
) -> None:
    """UW: a data frame names its transmitter (DT1 GG CC). A gauge set up with no channel
    takes the one transmitter it hears; once a second one is heard, no frame can be
    vouched for as this gauge's, so the reading stops instead of taking another leg's
    value."""
    gauge, end = _gauge(far_end, "uwave", [], unit="mm")
    end.push(b"DT10001+00000011.88M\r")
    assert gauge.read().value_mm == 11.88
    end.push(b"DT10002+00000022.22M\r")
    with pytest.raises(DriverError, match="0001 and 0002.*set its channel") as caught:
        gauge.read()
    assert not isinstance(caught.value, FrameError | DeviceBusy)  # not retried as garble
    end.push(b"DT10001+00000011.88M\r")
    with pytest.raises(DriverError, match="0001 and 0002"):
        gauge.read()  # nor is the first one known to be this gauge's any more


def test_sylvac_identification_of_another_maker_is_not_a_value(
    far_end: list[ScriptedPty],
) -> None:
    """Sylvac's own Opto-RS page (Sylvac Power manual, p. 15, "Identification") writes
    the line "XX" instrument "." OPT1 {"." OPT2} CR with "XX: Manufacturer" (the Bowers
    copy, p. 12, shows Sylvac's "SY"): an instrument sold under another maker's letters
    identifies itself with them when switched on, and that line is not a garbled reply."""
    gauge, _ = _gauge(far_end, "sylvac", [b"KA203.2.1\r+1.000\r"], unit="mm")
    assert gauge.read().value_mm == 1.0
