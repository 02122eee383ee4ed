"""Raw Digimatic frames as USB bridges emit them: 13 hex characters and CR/LF.

Nibbles (one ASCII character each), Mitutoyo QM-Height manual No. 99MAF600B,
6.2.1 "Digimatic output"::

    d1-d4  FFFF      header
    d5     0 / 8     sign + / -
    d6-d11 ######    six BCD digits
    d12    0-5       digits after the decimal point
    d13    0 / 1|8   unit mm / inch (8 is the same bit read in the other order)

``FFFF000012330`` = +0.123 mm (the manual's example, "normal measurement of
0.123 mm"; digits 000123, decimal position 3). An earlier INSTRUMENTS.md read it
as +1.233 mm: the manual wins. ``FFFF021076540`` = +21.0765 mm (linear scale
manual No. 99MBC095A, 6.2.1.5); ``FFFF801234530`` = -12.345 mm (measuring projector
manual No. 99MBA043A, 6-12).

Digimatic 2 (same page of 99MAF600B, "Digimatic 2 output") puts eight digits in
the frame: d1 = 8 (the format nibble, bits 0001 sent LSB first), d2 = F, d3-d4
the two most significant digits, d5 the sign, d6-d11 the other six, d12 the
decimal position, d13 the unit::

    8F 00 0 000123 3 0  ->  +0.123 mm  (the manual's example, as characters)

The manual's bit row for that example disagrees with its character row in d11
to d13 (it shows 5, 5, 1); the character row is the one consistent with "0.123
mm" and is what this decoder follows.

The frame carries its unit, so the value is converted from it; a configured unit
that differs is only a warning (the number stays right, in mm).

What no frame can show (99MAF600B, 6.2.1, "Tips"): at 0.00005 in a display has seven
digits, and a six-digit frame generally leaves out the highest (the tens of inches)
unless the instrument is set to send it; a value of 10 in or more then reads 10 in
short. Use Digimatic 2 (eight digits) or mm for such a range.

Bridges either answer any byte with one frame (polled) or stream a frame every
~10 ms (streaming, so old frames pile up unread).
"""

from __future__ import annotations

import logging
import re
from dataclasses import dataclass
from decimal import ROUND_HALF_EVEN, Decimal
from typing import Literal

import serial

from ogacq_drivers.errors import DriverError, FrameError
from ogacq_drivers.indicators.backend import Codec, Decoded, Example
from ogacq_drivers.indicators.base import (
    Reading,
    SerialIndicator,
    Unit,
    check_unit,
    reading_of,
    warn_other_unit,
)

log = logging.getLogger(__name__)

Mode = Literal["polled", "streaming"]
POLL_REQUEST = b"\r"  # bridges answer any byte; one byte asks for exactly one frame
DIGITS = 6
DIGITS_2 = 8  # Digimatic 2: d3-d4 and d6-d11
UNIT_NIBBLES: dict[str, Unit] = {"0": "mm", "1": "inch", "8": "inch"}

# Groups: high digits (Digimatic 2 only, else None), sign, six digits, point, unit.
_FRAME = re.compile(rb"(?:FFFF|8F([0-9]{2}))([08])([0-9]{6})([0-5])([018])(?:\r\n|\r|\n)")


@dataclass(frozen=True, slots=True)
class DigimaticFrame:
    """A decoded Digimatic frame (value in the unit the frame reports)."""

    value: Decimal
    decimals: int
    unit: Unit
    unit_nibble: str  # "0", "1" or "8", kept to log which inch convention a bridge uses
    digimatic2: bool = False  # an eight-digit Digimatic 2 frame


def encode_frame(value: float | Decimal, *, decimals: int, unit: Unit = "mm",
                 inch_nibble: str = "1", digimatic2: bool = False) -> bytes:
    """The frame for ``value`` in ``unit`` with ``decimals`` places (a Digimatic 2
    frame with eight digits when ``digimatic2``).

    Raises ValueError when the value needs more digits than the frame has."""
    if not 0 <= decimals <= 5:
        raise ValueError(f"Digimatic decimals must be 0..5, got {decimals}")
    if unit == "mm":
        unit_nibble = "0"
    elif unit == "inch" and inch_nibble in ("1", "8"):
        unit_nibble = inch_nibble
    else:
        raise ValueError(f"unit must be 'mm' or 'inch' (inch nibble 1 or 8), got "
                         f"{unit!r}/{inch_nibble!r}")
    exact = Decimal(str(value)) if isinstance(value, float) else Decimal(value)
    shown = exact.quantize(Decimal(1).scaleb(-decimals), rounding=ROUND_HALF_EVEN)
    digits = int(abs(shown).scaleb(decimals))
    width = DIGITS_2 if digimatic2 else DIGITS
    if digits >= 10**width:
        raise ValueError(f"{value} does not fit {width} digits with {decimals} decimals")
    sign = "8" if shown < 0 else "0"
    text = f"{digits:0{width}d}"
    head = f"8F{text[:2]}" if digimatic2 else "FFFF"
    return f"{head}{sign}{text[-DIGITS:]}{decimals}{unit_nibble}".encode("ascii") + b"\r\n"


def decode_frame(frame: bytes, *, where: str = "") -> DigimaticFrame:
    """Decode one frame (CR, LF or CR LF terminator included); FrameError if off grammar."""
    match = _FRAME.fullmatch(frame)
    if match is None:
        raise FrameError("not a Digimatic frame", where=where, frame=frame)
    high, sign, digits, point, unit_nibble = ((group or b"").decode("ascii")
                                              for group in match.groups())
    decimals = int(point)
    value = Decimal(int(high + digits)).scaleb(-decimals)
    if sign == "8":
        value = -value
    return DigimaticFrame(value=value, decimals=decimals, unit=UNIT_NIBBLES[unit_nibble],
                          unit_nibble=unit_nibble, digimatic2=match.group(1) is not None)


def decode(frame: bytes, *, where: str = "") -> Decoded:
    """The codec's decode: the frame carries its unit."""
    decoded = decode_frame(frame, where=where)
    return Decoded(decoded.value, decoded.decimals, decoded.unit)


def encode(value: Decimal, *, decimals: int, unit: Unit = "mm", channel: str = "") -> bytes:
    """The codec's encode: a six-digit frame, CR LF as the bridges send it."""
    return encode_frame(value, decimals=decimals, unit=unit)


# The manuals print the 13 characters; the bridges end them with CR LF.
CODEC = Codec(decode, encode, examples=(
    Example(b"FFFF000012330\r\n", "QM-Height manual 99MAF600B, 6.2.1: 0.123 mm", value_mm=0.123),
    Example(b"FFFF021076540\r\n", "LSM-6200 manual 99MBC095A, 6.2.1.5: 21.0765 mm",
            value_mm=21.0765),
    Example(b"FFFF801234530\r\n", "measuring projector manual 99MBA043A, 6-12: -12.345 mm",
            value_mm=-12.345),
    Example(b"8F00000012330\r\n", "99MAF600B, 6.2.1 Digimatic 2 output: 0.123 mm", value_mm=0.123),
), fixed_width=True)


class DigimaticBridge(SerialIndicator):
    """A Digimatic gauge behind a USB bridge, polled or streaming.

    ``unit`` is the unit the gauge is expected to display; frames carry their
    own unit, which is what the conversion uses (a mismatch is logged)."""

    def __init__(self, link: serial.Serial, *, where: str, unit: str, mode: Mode = "polled",
                 channel: str = "", timeout_s: float | None = None,
                 owns_link: bool = False) -> None:
        super().__init__(link, where=where, timeout_s=timeout_s, owns_link=owns_link)
        if mode not in ("polled", "streaming"):
            raise DriverError(f"mode must be 'polled' or 'streaming', got {mode!r}", where=where)
        self.unit: Unit = check_unit(unit, where=where)
        self.mode: Mode = mode
        self.channel = channel
        # Opening may have landed mid-stream, just like a flush.
        self._cut_by_flush = mode == "streaming"
        self._last_unit_nibble: str | None = None

    def flush_input(self) -> None:
        super().flush_input()
        # The flush may cut a streamed frame: its tail is dropped, not reported.
        self._cut_by_flush = self.mode == "streaming"

    def read(self, timeout_s: float | None = None) -> Reading:
        """Polled: flush, ask, decode the answer. Streaming: the next frame to arrive."""
        deadline = self._deadline(timeout_s)
        if self.mode == "polled":
            self.flush_input()
            self._send(POLL_REQUEST)
        frame, decoded = self._read_decoded(deadline, decode_frame)
        self._note_unit(decoded)
        return reading_of(decoded.value, decoded.unit, frame, channel=self.channel,
                          where=self.where)

    def _note_unit(self, decoded: DigimaticFrame) -> None:
        if decoded.unit_nibble == self._last_unit_nibble:
            return
        self._last_unit_nibble = decoded.unit_nibble
        if decoded.unit == "inch":
            log.info("%s: gauge reports inch (unit nibble %s); converting to mm", self.where,
                     decoded.unit_nibble)
        warn_other_unit(decoded.unit, self.unit, where=self.where)
