"""Mitutoyo "01A" ASCII protocol on a serial port (DMX-1, MUX-10, QM-Height).

The USB-ITN cable answers the same frames, but over USB (it is a HID device,
not a serial port, whatever ../shared/spec/INSTRUMENTS.md's "virtual-COM mode"
suggests): see :mod:`ogacq_drivers.indicators.usb_itn`.

Request: the channel digit and CR (``1\\r``). Reply, 13 bytes (Mitutoyo QM-Height
manual No. 99MAF600B, 6.2.2 "USB data output specifications", p. 67: D1 code "0",
D2 channel, D3 item "A", D4 sign, D5-D12 data with a floating decimal point, D13 CR;
9600 bps, 8 data bits, no parity, 1 stop bit)::

    0 <channel> A <sign> <8 characters, floating decimal point> CR
    01A+0000.123\\r     01A+000.1234\\r (inch)     02A-001.2340\\r

The frame has no unit: the unit is a gauge setting, recorded at setup, and the
number of decimals must fit it (see :mod:`ogacq_drivers.indicators.base`).
Errors are ``91`` and a digit (``911`` no data from the gauge, ``918`` busy);
they look numeric, so they are classified before any value parsing.
"""

from __future__ import annotations

import logging
import re
import time
from collections.abc import Iterable
from decimal import ROUND_HALF_EVEN, Decimal

import serial

from ogacq_drivers.errors import DeviceBusy, DeviceFault, DriverError, FrameError
from ogacq_drivers.indicators.backend import Codec, Decoded, Example
from ogacq_drivers.indicators.base import Reading, SerialIndicator, Unit, check_unit

log = logging.getLogger(__name__)

VALUE_WIDTH = 8  # characters of value, decimal point included
DEVICE_INFO_REQUEST = b"V\r"
BUSY_CODE = "918"
ERROR_MEANINGS = {
    "911": "no data from the gauge (is it connected, switched on, cable seated?)",
    "918": "interface busy",
}

_CHANNEL = re.compile(rb"[0-9A-Z]")
_READING = re.compile(rb"0([0-9A-Z])A([+-])([0-9.]{8})\r")
_VALUE_FIELD = re.compile(rb"[0-9]+\.[0-9]+")
_ERROR = re.compile(rb"91([0-9])\r")
_PRINTABLE = re.compile(rb"[\x20-\x7e]*\r")


def encode_request(channel: str = "1") -> bytes:
    """The request for one channel: ``b"1\\r"``."""
    raw = channel.encode("ascii", "replace")
    if not _CHANNEL.fullmatch(raw):
        raise ValueError(f"01A channel must be one digit or capital letter, got {channel!r}")
    return raw + b"\r"


def same_indicator(a: str | None, b: str | None) -> bool:
    """Whether gauges set to channels ``a`` and ``b`` of one port are asked the same
    request: a gauge with no channel is asked channel 1 (:class:`Mitutoyo01A`'s default)."""
    return (a or "1") == (b or "1")


def encode_reply(value: float | Decimal, *, decimals: int, channel: str = "1") -> bytes:
    """The reply frame for ``value`` (display unit) shown with ``decimals`` places.

    Raises ValueError when the value does not fit the 8-character field."""
    if not 1 <= decimals <= VALUE_WIDTH - 2:
        raise ValueError(f"decimals must be 1..{VALUE_WIDTH - 2}, got {decimals}")
    quantum = Decimal(1).scaleb(-decimals)
    exact = Decimal(str(value)) if isinstance(value, float) else Decimal(value)
    shown = exact.quantize(quantum, rounding=ROUND_HALF_EVEN)
    sign = b"-" if shown < 0 else b"+"
    field = f"{abs(shown):0{VALUE_WIDTH}.{decimals}f}".encode("ascii")
    if len(field) != VALUE_WIDTH:
        raise ValueError(f"{value} does not fit 8 characters with {decimals} decimals")
    return b"0" + encode_request(channel)[:1] + b"A" + sign + field + b"\r"


def encode_error(code: str | int) -> bytes:
    """An error frame: ``encode_error("911") == b"911\\r"``."""
    text = str(code)
    if not re.fullmatch(r"91[0-9]", text):
        raise ValueError(f"01A error codes are 910..919, got {code!r}")
    return text.encode("ascii") + b"\r"


def decode_reply(frame: bytes, *, where: str = "") -> Decoded:
    """Decode one reply frame (terminator included): the value in the gauge's display
    unit, which the frame does not name (a gauge setting), and its channel.

    Raises :class:`DeviceBusy` for ``918``, :class:`DeviceFault` for other
    ``91x`` codes and :class:`FrameError` for anything off the grammar."""
    error = _ERROR.fullmatch(frame)
    if error is not None:
        code = "91" + error.group(1).decode("ascii")
        if code == BUSY_CODE:
            raise DeviceBusy("gauge interface busy (918)", code=code, where=where)
        meaning = ERROR_MEANINGS.get(code, "error reported by the interface")
        raise DeviceFault(f"error {code}: {meaning}", code=code, where=where)
    match = _READING.fullmatch(frame)
    if match is None:
        raise FrameError("not a 01A reply", where=where, frame=frame)
    channel, sign, field = match.groups()
    if not _VALUE_FIELD.fullmatch(field):
        raise FrameError("01A value field is not digits with one decimal point", where=where,
                         frame=frame)
    value = Decimal(field.decode("ascii"))  # digits, a point, digits: always a number
    if sign == b"-":
        value = -value
    decimals = len(field) - field.index(b".") - 1
    return Decoded(value, decimals, None, channel.decode("ascii"))


decode = decode_reply  # the codec's decode


def encode(value: Decimal, *, decimals: int, unit: Unit = "mm", channel: str = "") -> bytes:
    """The codec's encode: the unit is not in the frame, only in its decimals."""
    return encode_reply(value, decimals=decimals, channel=channel or "1")


#: The frames of the QM-Height manual and of INSTRUMENTS.md, 01A (the error codes there
#: are one informal source, L).
_QM = "QM-Height manual 99MAF600B, 6.2.2 p. 67"
CODEC = Codec(decode, encode, examples=(
    Example(b"01A+0000.125\r", f"{_QM}: mm at 0.005, 0.125", value_mm=0.125),
    Example(b"01A+00.12345\r", f"{_QM}: inch at 0.00005, 0.12345", value_mm=3.13563, unit="inch"),
    Example(b"01A+0000.123\r", f"{_QM}: mm at 0.001, 0.123 (and INSTRUMENTS.md)", value_mm=0.123),
    Example(b"01A+000.1234\r", f"{_QM}: inch at 0.0001, 0.1234 (and INSTRUMENTS.md)",
            value_mm=3.13436, unit="inch"),
    Example(b"01A-001.2340\r", "INSTRUMENTS.md 01A", value_mm=-31.3436, unit="inch"),
    Example(b"911\r", "INSTRUMENTS.md 01A errors: no data from the gauge", error=DeviceFault),
    Example(b"918\r", "INSTRUMENTS.md 01A errors: busy", error=DeviceBusy),
), fixed_width=True)


class Mitutoyo01A(SerialIndicator):
    """A gauge behind a Mitutoyo 01A interface (one channel of a multiplexer).

    ``unit`` is the unit the gauge displays (a gauge setting the frame does not
    carry); ``decimals`` the decimal places it shows (default: 1-3 for mm,
    4-5 for inch). Several drivers may share one link, one per channel, as long
    as they are used from one thread."""

    def __init__(self, link: serial.Serial, *, where: str, unit: str, channel: str = "1",
                 decimals: int | Iterable[int] | None = None, timeout_s: float | None = None,
                 busy_retries: int = 5, busy_retry_delay_s: float = 0.05,
                 owns_link: bool = False) -> None:
        super().__init__(link, where=where, timeout_s=timeout_s, owns_link=owns_link)
        self.unit: Unit = check_unit(unit, where=where)
        self.channel = channel
        try:
            self._request = encode_request(channel)
        except ValueError as exc:
            raise DriverError(str(exc), where=where) from None
        self._set_unit(unit, decimals)
        self.busy_retries = busy_retries
        self.busy_retry_delay_s = busy_retry_delay_s

    def read(self, timeout_s: float | None = None) -> Reading:
        """Request and decode one value; ``918`` is retried a few times ~50 ms apart."""
        deadline = self._deadline(timeout_s)
        retries_left = self.busy_retries
        while True:
            try:
                return self._exchange(deadline)
            except DeviceBusy:
                pause_s = self.busy_retry_delay_s
                if retries_left <= 0 or time.monotonic() + pause_s >= deadline:
                    raise
                retries_left -= 1
                log.debug("%s: busy (918), retrying in %.0f ms", self.where, pause_s * 1e3)
                time.sleep(pause_s)

    def device_info(self, timeout_s: float | None = None) -> str:
        """The interface's identification (``V\\r``)."""
        self.flush_input()
        self._send(DEVICE_INFO_REQUEST)
        frame = self._read_frame(self._deadline(timeout_s))
        if _ERROR.fullmatch(frame):
            decode_reply(frame, where=self.where)  # raises the classified error
        if not _PRINTABLE.fullmatch(frame):
            raise FrameError("device information is not printable text", where=self.where,
                             frame=frame)
        return frame[:-1].decode("ascii").strip()

    def _exchange(self, deadline: float) -> Reading:
        self.flush_input()
        self._send(self._request)
        frame = self._read_frame(deadline)
        reply = decode_reply(frame, where=self.where)
        if reply.channel != self.channel:
            raise FrameError(f"reply from channel {reply.channel}, asked channel {self.channel}",
                             where=self.where, frame=frame)
        return self._checked(reply.value, reply.decimals, frame, self.channel)
