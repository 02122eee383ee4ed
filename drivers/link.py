"""Open a serial link from a device path, a COM port name or a pyserial URL.

Every driver receives an already open link (pymeasure habit), so this is the one
place that turns a configured port string into a ``serial.Serial``-like object:
``/dev/ttyUSB0``, ``/dev/pts/5``, ``COM3``, ``socket://host:port``, ``loop://``,
``spy://...`` all go through :func:`serial.serial_for_url`, and every failure to
open becomes a :class:`~ogacq_drivers.errors.LinkError` naming the port and saying
what to check.
"""

from __future__ import annotations

import errno
import logging
import os
from dataclasses import dataclass

import serial

from ogacq_drivers.errors import LinkError

log = logging.getLogger(__name__)

_PARITIES = {"N": serial.PARITY_NONE, "E": serial.PARITY_EVEN, "O": serial.PARITY_ODD}

# What a technician should check, by the errno behind a failed open.
_HINTS = {
    errno.ENOENT: "no such device: is the USB adapter plugged in and the port name right?",
    errno.EACCES: "permission denied: is the user in the 'dialout' group?",
    errno.EBUSY: "the port is busy: is another program using it?",
    errno.ECONNREFUSED: "connection refused: is the serial server or simulator running?",
    errno.EHOSTUNREACH: "host unreachable: check the network address",
    errno.ETIMEDOUT: "connection timed out: check the network address",
}


@dataclass(frozen=True, slots=True)
class LinkSettings:
    """Line settings of one serial link.

    ``timeout_s`` is the longest a single low-level read blocks, not a reply
    deadline: drivers loop on short reads until their own deadline, so a small
    value keeps deadlines precise without wasting line time (a read returns as
    soon as a byte arrives)."""

    baudrate: int = 9600
    bytesize: int = 8
    parity: str = "N"
    stopbits: float = 1
    timeout_s: float = 0.02
    dtr: bool | None = None  # None leaves pyserial's default (asserted)
    rts: bool | None = None

    @property
    def bits_per_byte(self) -> int:
        """Bits on the wire per byte: start bit, data, parity, stop bits (1.5 rounds up)."""
        parity_bits = 0 if self.parity == "N" else 1
        return 1 + self.bytesize + parity_bits + int(self.stopbits + 0.5)

    @property
    def byte_time_s(self) -> float:
        """Seconds one byte occupies the line at this baud rate."""
        return self.bits_per_byte / self.baudrate


def is_url(port: str) -> bool:
    """True for pyserial URLs (``socket://``, ``loop://``, ``spy://``...)."""
    return "://" in port


def _errno_of(exc: BaseException) -> int | None:
    """The errno behind a pyserial exception (pyserial keeps it in different places)."""
    seen: set[int] = set()
    current: BaseException | None = exc
    while current is not None and id(current) not in seen:
        seen.add(id(current))
        code = getattr(current, "errno", None)
        if isinstance(code, int):
            return code
        current = current.__cause__ or current.__context__
    text = str(exc)
    if "Connection refused" in text:
        return errno.ECONNREFUSED
    return errno.ENOENT if "No such file or directory" in text else None


def open_link(port: str, settings: LinkSettings | None = None, *, where: str = "") -> serial.Serial:
    """Open ``port`` with ``settings`` and return the open link.

    Raises :class:`LinkError` naming the port (and ``where``, the gauge or
    controller it serves) when the settings are invalid or the port cannot be
    opened: missing device, no permission, port in use, refused socket."""
    settings = settings or LinkSettings()
    where = where or port
    if settings.parity not in _PARITIES:
        raise LinkError(f"invalid parity {settings.parity!r} for {port} (use N, E or O)",
                        where=where)
    local_device = not is_url(port) and os.name == "posix"
    try:
        link = serial.serial_for_url(
            port,
            do_not_open=True,
            baudrate=settings.baudrate,
            bytesize=settings.bytesize,
            parity=_PARITIES[settings.parity],
            stopbits=settings.stopbits,
            timeout=settings.timeout_s,
            # A second program on the same gauge would steal half the replies.
            exclusive=True if local_device else None,
        )
    except (ValueError, serial.SerialException) as exc:
        raise LinkError(f"cannot use {port} with {settings}: {exc}", where=where) from exc
    # Set before opening so the lines come up in the right state (a Sylvac
    # Opto-RS cable is powered from DTR high / RTS low).
    if settings.dtr is not None:
        link.dtr = settings.dtr
    if settings.rts is not None:
        link.rts = settings.rts
    try:
        link.open()
    except (serial.SerialException, OSError) as exc:
        hint = _HINTS.get(_errno_of(exc) or -1, "")
        if "exclusively lock" in str(exc):
            hint = _HINTS[errno.EBUSY]
        # pyserial's message repeats the port and the errno; a known errno's hint
        # says the cause once, in the technician's terms.
        raise LinkError(f"cannot open {port}: {hint or exc}", where=where) from exc
    log.debug("opened %s (%s) for %s", port, settings, where)
    return link
