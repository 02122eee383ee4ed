"""Mitutoyo USB-ITN cable in keyboard mode (its factory setting): the value is typed.

The cable is a USB HID keyboard (pytuyo README: "enumerates as an HID device");
when its data switch is pressed it types the displayed value and Enter (issue
12; we had no Mitutoyo text at hand for the exact characters, so the grammar is
the plain one, an optional sign, digits, an optional point and digits: no source
beyond that). It is read from its own input event device, found by its vendor
and product id (0FE7:4001, pytuyo) and grabbed, through
:mod:`ogacq_drivers.input_link`; never from the operator's keyboard.

Key codes are the kernel's (``linux/input-event-codes.h``): the digit row
(KEY_1 = 2 ... KEY_0 = 11), KEY_MINUS 12, KEY_DOT 52, KEY_ENTER 28, the keypad
(KEY_KP7 = 71 ... KEY_KPDOT = 83, KEY_KPMINUS 74, KEY_KPPLUS 78, KEY_KPENTER 96),
and Shift (42, 54) with KEY_EQUAL (13) for ``+``. Any other key makes the line
garbage. Values are pushed, like a U-WAVE receiver's: ``read`` returns the next
typed line; ``flush_input`` (``read_stable`` calls it) drops older lines, and a
line it cut in the middle is skipped whole, never read as a shorter number.

The typed value has no unit: the unit is recorded at setup, and the decimals
must fit it (as for the 01A frames).
"""

from __future__ import annotations

import contextlib
import logging
import os
import re
import select
import time
from collections.abc import Iterable
from decimal import Decimal
from typing import Any

from ogacq_drivers.errors import DeviceTimeout, FrameError, LinkError
from ogacq_drivers.indicators.backend import Codec, Decoded, Example, FoundPort
from ogacq_drivers.indicators.base import IndicatorDriver, Reading, Unit
from ogacq_drivers.indicators.usb_itn import PRODUCT_ID, VENDOR_ID
from ogacq_drivers.input_link import (
    EVENT,
    find_event_devices,
    open_event_device,
    resolve_event_device,
)

log = logging.getLogger(__name__)

EV_KEY = 1  # linux/input-event-codes.h
KEY_PRESS = 1  # value of a key press (0 release, 2 autorepeat)
SHIFT_KEYS = frozenset({42, 54})  # KEY_LEFTSHIFT, KEY_RIGHTSHIFT
ENTER_KEYS = frozenset({28, 96})  # KEY_ENTER, KEY_KPENTER
KEY_EQUAL = 13
KEY_CHARS: dict[int, str] = {
    **{code: str(digit % 10) for digit, code in enumerate(range(2, 12), 1)},  # KEY_1..KEY_0
    12: "-",  # KEY_MINUS
    52: ".",  # KEY_DOT
    **dict(zip(range(71, 84), "789-456+1230.", strict=True)),  # the keypad, KEY_KP7..KEY_KPDOT
}
CHAR_KEYS: dict[str, int] = {"-": 12, ".": 52, **{str(d % 10): 1 + d for d in range(1, 11)}}
MAX_LINE = 32  # characters before Enter; more is garbage

_VALUE = re.compile(r"([+-]?)([0-9]+)(?:\.([0-9]+))?")


def key_events(text: str) -> list[tuple[int, int]]:
    """(code, value) presses and releases that type ``text`` and Enter (simulator)."""
    events: list[tuple[int, int]] = []
    for char in text:
        if char == "+":
            events += [(42, 1), (KEY_EQUAL, 1), (KEY_EQUAL, 0), (42, 0)]
        else:
            code = CHAR_KEYS.get(char, 30)  # KEY_A: a character no value has
            events += [(code, 1), (code, 0)]
    return events + [(28, 1), (28, 0)]


def decode_line(line: str, *, where: str = "") -> tuple[Decimal, int]:
    """The value and its decimals; FrameError when the line is not a number."""
    match = _VALUE.fullmatch(line)
    if match is None:
        raise FrameError("typed line is not a value", where=where, frame=line.encode())
    sign, whole, fraction = match.groups()
    value = Decimal(f"{whole}.{fraction or '0'}")
    return (-value if sign == "-" else value), len(fraction or "")


def decode(frame: bytes, *, where: str = "") -> Decoded:
    """The codec's decode of one typed line and its Enter, as a reading records it
    (``b"1.233\\n"``); the value has no unit (the unit is set at setup)."""
    body, enter = frame[:-1], frame[-1:]
    if enter != b"\n" or not body.isascii():
        raise FrameError("not a typed line and its Enter", where=where, frame=frame)
    value, decimals = decode_line(body.decode("ascii"), where=where)
    return Decoded(value, decimals, None)


def encode(value: Decimal, *, decimals: int, unit: Unit = "mm", channel: str = "") -> bytes:
    """The codec's encode: the value as the cable types it, and Enter."""
    return f"{Decimal(value):.{decimals}f}\n".encode("ascii")


_NO_SOURCE = "no source for the typed characters (issue 12: the plain grammar)"
CODEC = Codec(decode, encode, examples=(
    Example(b"1.233\n", _NO_SOURCE, value_mm=1.233),
    Example(b"-0.0500\n", _NO_SOURCE + "; an inch display", value_mm=-1.27, unit="inch"),
    Example(b"1.2A3\n", _NO_SOURCE + "; a key no value has", error=FrameError),
), fixed_width=False)  # typed as long as the value needs


def find_keyboards() -> list[FoundPort]:
    """The input devices of USB-ITN cables in keyboard mode (found by their USB ids)."""
    return [FoundPort(str(node), "Mitutoyo USB-ITN cable typing as a keyboard")
            for node in find_event_devices(VENDOR_ID, PRODUCT_ID)]


class UsbItnKeyboard(IndicatorDriver):
    """A gauge on a USB-ITN cable left in keyboard mode (an :class:`Indicator`)."""

    default_timeout_s = 5.0  # someone (or a foot switch) presses the data switch

    def __init__(self, fd: int, node: str, *, where: str, unit: str,
                 decimals: int | Iterable[int] | None = None, channel: str = "",
                 timeout_s: float | None = None) -> None:
        super().__init__(where=where, timeout_s=timeout_s)
        self.fd = fd
        self.node = node
        self._set_unit(unit, decimals)
        self.channel = channel
        self._raw = bytearray()  # bytes of an incomplete event
        self._line: list[str] = []
        self._lines: list[str] = []
        self._shift = False
        self._skip_line = False  # the first line after a cut is not whole

    @classmethod
    def open(cls, port: str, *, where: str, unit: str, **options: Any) -> UsbItnKeyboard:
        """``keyboard`` (the cable with the USB-ITN's ids) or ``/dev/input/eventN``."""
        node = resolve_event_device(port, VENDOR_ID, PRODUCT_ID, where=where,
                                    what="Mitutoyo USB-ITN")
        fd = open_event_device(node, where=where)
        try:
            return cls(fd, str(node), where=where, unit=unit, **options)
        except BaseException:
            os.close(fd)
            raise

    # ------------------------------------------------------------ the contract
    def read(self, timeout_s: float | None = None) -> Reading:
        """The next value typed by the cable."""
        deadline = self._deadline(timeout_s)
        while not self._lines:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise DeviceTimeout("no value typed before the deadline (data switch pressed? "
                                    "cable in keyboard mode?)", where=self.where)
            self._pump(min(remaining, 0.05))
        line = self._lines.pop(0)
        value, decimals = decode_line(line, where=self.where)
        frame = line.encode("ascii") + b"\n"
        return self._checked(value, decimals, frame, self.channel)

    def flush_input(self) -> None:
        """Drop the lines typed before now; a line cut in the middle is skipped whole."""
        while self._pump(0):
            pass
        self._lines.clear()
        if self._line or self._raw:
            self._skip_line = True
        self._line.clear()

    def close(self) -> None:
        if self.fd >= 0:
            with contextlib.suppress(OSError):
                os.close(self.fd)  # also ends the grab
            self.fd = -1

    def __repr__(self) -> str:
        return f"UsbItnKeyboard(where={self.where!r}, node={self.node!r})"

    # ---------------------------------------------------------------- the wire
    def _pump(self, wait_s: float) -> bool:
        """Read and decode what arrived within ``wait_s``; True when bytes came."""
        try:
            ready, _, _ = select.select([self.fd], [], [], wait_s)
            if not ready:
                return False
            data = os.read(self.fd, EVENT.size * 64)
        except OSError as exc:  # ENODEV: the kernel removed the device
            raise LinkError(f"lost {self.node} ({exc.strerror}); was the cable unplugged?",
                            where=self.where) from exc
        if not data:
            raise LinkError(f"{self.node} closed; was the cable unplugged?", where=self.where)
        self._raw += data
        whole = len(self._raw) - len(self._raw) % EVENT.size
        for _sec, _usec, kind, code, value in EVENT.iter_unpack(bytes(self._raw[:whole])):
            if kind == EV_KEY:
                self._key(code, value)
        del self._raw[:whole]
        return True

    def _key(self, code: int, value: int) -> None:
        if code in SHIFT_KEYS:
            self._shift = value != 0
            return
        if value != KEY_PRESS:
            return
        if code in ENTER_KEYS:
            line = "".join(self._line)
            self._line.clear()
            if self._skip_line:
                self._skip_line = False
                log.debug("%s: dropped a line cut by a flush: %r", self.where, line)
            elif line:
                self._lines.append(line)
            return
        if self._shift and code == KEY_EQUAL:
            char = "+"
        else:
            char = "?" if self._shift else KEY_CHARS.get(code, "?")
        if len(self._line) < MAX_LINE:
            self._line.append(char)
