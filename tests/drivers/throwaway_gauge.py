"""A throwaway gauge protocol, whole in this one module: its codec, its driver, its
simulated instrument and its connection hints. Nothing else in the project names it;
``tests/drivers/test_new_protocol.py`` registers :data:`BACKEND` and runs it end to
end, which shows that adding a protocol is one module and its tests.

The wire (made up for the test, no source): 19200 8N1; the request ``READ`` and CR;
the reply ``VAL=<sign><4 digits>.<3 digits>;U=<MM|IN>`` and LF, the unit in the
frame; an error ``ERR=<2 digits>`` and LF.
"""

from __future__ import annotations

import re
import time
from decimal import ROUND_HALF_EVEN, Decimal

import serial

from ogacq_drivers.errors import DeviceFault, FrameError
from ogacq_drivers.indicators.backend import (
    Backend,
    Codec,
    ConnectionHints,
    Decoded,
    Example,
)
from ogacq_drivers.indicators.base import Reading, SerialIndicator, Unit, check_unit
from ogacq_drivers.link import LinkSettings
from ogacq_drivers.sim.gauges import LineDevice

REQUEST = b"READ\r"
_REPLY = re.compile(rb"VAL=([+-])([0-9]{4}\.[0-9]{3});U=(MM|IN)\n")
_ERROR = re.compile(rb"ERR=([0-9]{2})\n")
_UNITS: dict[bytes, Unit] = {b"MM": "mm", b"IN": "inch"}


# ------------------------------------------------------------------- the codec


def decode(frame: bytes, *, where: str = "") -> Decoded:
    error = _ERROR.fullmatch(frame)
    if error is not None:
        code = error.group(1).decode("ascii")
        raise DeviceFault(f"throwaway gauge error {code}", code=code, where=where)
    reply = _REPLY.fullmatch(frame)
    if reply is None:
        raise FrameError("not a throwaway reply", where=where, frame=frame)
    sign, digits, unit = reply.groups()
    value = Decimal(digits.decode("ascii"))
    return Decoded(-value if sign == b"-" else value, 3, _UNITS[unit])


def encode(value: Decimal, *, decimals: int, unit: Unit = "mm", channel: str = "") -> bytes:
    if decimals != 3:
        raise ValueError("the throwaway display shows 3 decimals")
    shown = Decimal(value).quantize(Decimal("0.001"), rounding=ROUND_HALF_EVEN)
    digits = f"{abs(shown):08.3f}"
    if len(digits) != 8:
        raise ValueError(f"{value} does not fit 4 digits")
    letters = "MM" if unit == "mm" else "IN"
    return f"VAL={'-' if shown < 0 else '+'}{digits};U={letters}\n".encode("ascii")


CODEC = Codec(
    decode,
    encode,
    examples=(
        Example(b"VAL=+0001.233;U=MM\n", "no source: made up for the test", value_mm=1.233),
        Example(b"VAL=-0000.050;U=IN\n", "no source: made up for the test", value_mm=-1.27),
        Example(b"ERR=07\n", "no source: made up for the test", error=DeviceFault),
    ),
    fixed_width=True,
)


# ------------------------------------------------------------------ the driver


class ThrowawayGauge(SerialIndicator):
    """Ask, then decode the reply (an :class:`~ogacq_drivers.indicators.base.Indicator`)."""

    def __init__(self, link: serial.Serial, *, where: str, unit: str, channel: str = "",
                 timeout_s: float | None = None, owns_link: bool = False) -> None:
        super().__init__(link, where=where, timeout_s=timeout_s, owns_link=owns_link)
        self.unit: Unit = check_unit(unit, where=where)
        self.channel = channel

    def read(self, timeout_s: float | None = None) -> Reading:
        deadline = self._deadline(timeout_s)
        self.flush_input()
        self._send(REQUEST)
        frame, decoded = self._read_decoded(deadline, decode)
        unit = decoded.unit or self.unit
        return Reading(decoded.value_mm(), frame, time.time(), self.channel, unit, self.where)


# ------------------------------------------------------- the simulated instrument


class ThrowawayDevice(LineDevice):
    """Answers ``READ`` with its value, anything else with error 01."""

    MAX_DECIMALS = 3
    DEFAULT_ERROR = "07"

    def on_line(self, command: str) -> None:
        if command == "READ":
            self.gauge.emit(self.gauge.default_channel)
        else:
            self.gauge.send(self.error_frame("01", ""))

    def value_frame(self, value: Decimal, *, decimals: int, unit: Unit, channel: str,
                    inch_code: str) -> bytes:
        return encode(value, decimals=3, unit=unit)

    def error_frame(self, code: str, channel: str) -> bytes:
        if not re.fullmatch(r"[0-9]{2}", code):
            raise ValueError(f"throwaway error codes are two digits, got {code!r}")
        return f"ERR={code}\n".encode("ascii")


# ------------------------------------------------------------------- the entry

BACKEND = Backend(
    "throwaway protocol of the tests",
    driver=f"{__name__}:ThrowawayGauge",
    codec=f"{__name__}:CODEC",
    simulator=f"{__name__}:ThrowawayDevice",
    hints=ConnectionHints("a serial device (/dev/ttyUSB0) or socket://host:port",
                          note="The throwaway gauge answers READ."),
    settings=LinkSettings(baudrate=19200, bytesize=8, parity="N", stopbits=1),
)
