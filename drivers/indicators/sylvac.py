"""Sylvac Opto-RS duplex cable: 4800 baud 7E2, powered from DTR high / RTS low.

Source: Sylvac "User's manual for OPTO-RS cable connections" (reproduced in the
Bowers Group / Sylvac Opto instruments user manual, pages 12-13): line settings,
data format, ERR0-3, the identification line and both cables' wiring. The
simplex cable is :mod:`ogacq_drivers.indicators.sylvac_simplex`.

Request ``?\\r``; reply ``[+|-| ]int.frac\\r`` in the unit set on the gauge
(the ``MM`` / ``IN`` commands set it), so the unit is recorded at setup and the
number of decimals must fit it. Errors: ``ERR0`` sensor, ``ERR1`` bad command,
``ERR2`` parity, ``ERR3`` out of range. In tolerance mode the gauge appends
``<``, ``=`` or ``>``; it is accepted and ignored. Some duplex instruments echo
commands; an echoed ``?`` is skipped.

The reply has no fixed width, so a lost digit still leaves a valid frame. A
lost fractional digit is caught because the number of decimals is pinned to
one value (default 3 in mm, 0.001 mm; 5 in inch, 0.00005 in; the gauge's
RES2 setting). A digit lost from the integer part cannot be detected from the
frame alone; the 7E2 line's parity is the only guard there, and only because the
driver has the kernel check it (pyserial leaves it unchecked: see
:func:`ogacq_drivers.indicators.base.flag_line_errors`).

At power-on the instrument sends one identification line, ``SY`` instrument
``.`` option {``.`` option} CR, e.g. ``SY235.1`` (same manual, "Identification"):
it is recorded and skipped, not counted as a garbled reply. ``SY`` is Sylvac's own
mark: Sylvac's generic Opto-RS page (Sylvac Power manual, p. 15) writes the field
``XX``, "Manufacturer", so any two capital letters are taken as the maker's.
"""

from __future__ import annotations

import errno
import logging
import re
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from decimal import ROUND_HALF_EVEN, Decimal

import serial

from ogacq_drivers.errors import DeviceFault, FrameError
from ogacq_drivers.indicators.backend import Codec, Decoded, Example
from ogacq_drivers.indicators.base import Reading, SerialIndicator, Unit, check_unit, link_errors

log = logging.getLogger(__name__)

REQUEST = b"?\r"
# One layout per unit (see the module docstring): RES2 shows 0.001 mm / 0.00005 in.
DEFAULT_DECIMALS: dict[Unit, int] = {"mm": 3, "inch": 5}
UNIT_COMMANDS: dict[Unit, bytes] = {"mm": b"MM\r", "inch": b"IN\r"}
ERROR_MEANINGS = {
    "0": "sensor error (moved too fast? scale distance?)",
    "1": "command not understood",
    "2": "parity error on the line (check 4800 7E2)",
    "3": "out of measuring range",
}

_VALUE = re.compile(rb"([+\- ])([0-9]{1,9})\.([0-9]{1,7})([<=>]?)\r")
_ERROR = re.compile(rb"ERR([0-9])\r")
# "SY" (the maker, "XX" in the Sylvac Power manual p. 15) | instrument (203, 235,
# 233...) | "." | OPT1 | {"." | OPT2} | CR. A value starts with its sign, an error
# with "ERR" and no ".": neither can match.
_IDENTIFICATION = re.compile(rb"[A-Z]{2}([0-9A-Za-z]+)((?:\.[0-9A-Za-z]+)+)\r")


@dataclass(frozen=True, slots=True)
class SylvacReply:
    """A decoded reply (value in the gauge's display unit)."""

    value: Decimal
    decimals: int
    tolerance_flag: str = ""  # "<", "=" or ">" in tolerance mode


def decode_identification(frame: bytes) -> str | None:
    """``"SY235.1"`` for the power-on identification line ``SY235.1\\r``; None otherwise."""
    return None if _IDENTIFICATION.fullmatch(frame) is None else frame[:-1].decode("ascii")


def encode_identification(instrument: str = "235", *options: str) -> bytes:
    """The identification line: ``encode_identification("235", "1") == b"SY235.1\\r"``."""
    frame = ".".join(("SY" + instrument, *(options or ("1",)))).encode("ascii") + b"\r"
    if decode_identification(frame) is None:
        raise ValueError(f"not an identification line: {frame!r}")
    return frame


def read_reply(read_frame: Callable[[], bytes], *, where: str, skip: bytes = b"") -> bytes:
    """The next frame that is a reply: the identification line a gauge sends when
    switched on (and an echoed ``skip`` request) is logged and skipped."""
    while True:
        frame = read_frame()
        if skip and frame == skip:
            log.debug("%s: skipping the echoed request", where)
            continue
        ident = decode_identification(frame)
        if ident is None:
            return frame
        log.info("%s: instrument identifies itself as %s (switched on)", where, ident)


def encode_reply(value: float | Decimal, *, decimals: int, tolerance_flag: str = "") -> bytes:
    """The reply for ``value`` with ``decimals`` places (sign ``+``/``-``)."""
    if not 1 <= decimals <= 7:
        raise ValueError(f"decimals must be 1..7, got {decimals}")
    if tolerance_flag not in ("", "<", "=", ">"):
        raise ValueError(f"tolerance flag must be '', '<', '=' or '>', got {tolerance_flag!r}")
    exact = Decimal(str(value)) if isinstance(value, float) else Decimal(value)
    shown = exact.quantize(Decimal(1).scaleb(-decimals), rounding=ROUND_HALF_EVEN)
    sign = "-" if shown < 0 else "+"
    text = f"{sign}{abs(shown):.{decimals}f}{tolerance_flag}\r"
    if len(text) > 20:
        raise ValueError(f"{value} is too large for a Sylvac reply")
    return text.encode("ascii")


def encode_error(code: int | str) -> bytes:
    """``encode_error(3) == b"ERR3\\r"`` (also accepts ``"ERR3"``)."""
    text = str(code).removeprefix("ERR")
    if not re.fullmatch(r"[0-9]", text):
        raise ValueError(f"Sylvac error codes are one digit, got {code!r}")
    return f"ERR{text}\r".encode("ascii")


def decode_reply(frame: bytes, *, where: str = "") -> SylvacReply:
    """Decode a reply (CR included): DeviceFault for ``ERRn``, FrameError off grammar."""
    error = _ERROR.fullmatch(frame)
    if error is not None:
        code = error.group(1).decode("ascii")
        meaning = ERROR_MEANINGS.get(code, "unknown error")
        raise DeviceFault(f"gauge error ERR{code}: {meaning}", code=f"ERR{code}", where=where)
    match = _VALUE.fullmatch(frame)
    if match is None:
        raise FrameError("not a Sylvac reply", where=where, frame=frame)
    sign, whole, fraction, flag = (part.decode("ascii") for part in match.groups())
    value = Decimal(f"{whole}.{fraction}")
    if sign == "-":
        value = -value
    return SylvacReply(value=value, decimals=len(fraction), tolerance_flag=flag)


def decode(frame: bytes, *, where: str = "") -> Decoded:
    """The codec's decode: a reply has no unit field (the unit is set on the gauge)."""
    reply = decode_reply(frame, where=where)
    return Decoded(reply.value, reply.decimals, None)


def encode(value: Decimal, *, decimals: int, unit: Unit = "mm", channel: str = "") -> bytes:
    """The codec's encode: the unit is not in the frame, only in its decimals."""
    return encode_reply(value, decimals=decimals)


# The manual gives the layout, not example values: the value frames are built from it.
_MANUAL = "Opto-RS manual (Sylvac / Bowers Opto instruments manual, pp. 12-13)"
CODEC = Codec(decode, encode, examples=(
    Example(b"+12.345\r", f"{_MANUAL}, data format: sign, integer, '.', fraction, CR",
            value_mm=12.345),
    Example(b" 0.005\r", f"{_MANUAL}, data format: the sign may be a space", value_mm=0.005),
    Example(b"-0.04855\r", f"{_MANUAL}, data format: an inch display at 0.00005 in",
            value_mm=-1.23317, unit="inch"),
    Example(b"ERR3\r", f"{_MANUAL}, errors: 3 exceeded measurement range", error=DeviceFault),
    Example(b"SY235.1\r", f"{_MANUAL}, identification: sent at power-on, not a value",
            error=FrameError),
), fixed_width=False)  # the integer part has as many digits as the value needs


class SylvacOptoRS(SerialIndicator):
    """A Sylvac gauge on an Opto-RS duplex cable.

    ``unit`` is the unit set on the gauge (recorded at setup); ``decimals`` the
    places it shows (default 3 for mm, 5 for inch; 2 / 4 for a gauge at RES3)."""

    def __init__(self, link: serial.Serial, *, where: str, unit: str,
                 decimals: int | Iterable[int] | None = None, channel: str = "",
                 timeout_s: float | None = None, owns_link: bool = False) -> None:
        super().__init__(link, where=where, timeout_s=timeout_s, owns_link=owns_link)
        self.channel = channel
        if decimals is None:
            decimals = DEFAULT_DECIMALS[check_unit(unit, where=where)]
        self._set_unit(unit, decimals)
        self._power_cable()

    def _power_cable(self) -> None:
        """DTR high, RTS low: the cable takes its power from the handshake lines."""
        try:
            self.link.dtr = True
            self.link.rts = False
        except OSError as exc:
            # A pty or a virtual port has no modem lines; pyserial itself ignores
            # these two errors when it opens such a port.
            if exc.errno not in (errno.ENOTTY, errno.EINVAL):
                with link_errors(self.where, "powering the Opto-RS cable (DTR high, RTS low)"):
                    raise
            log.debug("%s: no modem lines to power the cable from (%s)", self.where, exc)

    def read(self, timeout_s: float | None = None) -> Reading:
        """Request and decode one value."""
        deadline = self._deadline(timeout_s)
        self.flush_input()
        self._send(REQUEST)
        return self._reading(read_reply(lambda: self._read_frame(deadline), where=self.where,
                                        skip=REQUEST))

    def _reading(self, frame: bytes) -> Reading:
        """The reading of a reply, whose decimals must fit the unit set on the gauge."""
        reply = decode_reply(frame, where=self.where)
        return self._checked(reply.value, reply.decimals, frame, self.channel)
