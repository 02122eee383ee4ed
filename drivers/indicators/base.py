"""The one contract of indicator drivers, and what the drivers share.

- :class:`Reading`: one value in mm with the raw frame it came from.
- :class:`Indicator`: the ``typing.Protocol`` a campaign runner talks to.
- :func:`read_stable`: flush stale input, then wait for N consecutive values
  within a tolerance (free-running bridges buffer old frames).
- Unit helpers that make "an inch value taken as mm" impossible: where a frame
  has no unit field, the unit recorded at setup fixes which decimal layouts
  are accepted, and the default layouts of mm and inch do not overlap.
- :class:`SerialIndicator`: a base class with the shared link handling
  (terminator-delimited reads against a deadline, flush, error mapping).
"""

from __future__ import annotations

import logging
import os
import time
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from decimal import Decimal
from typing import Literal, Protocol, Self, TypeVar, runtime_checkable

import serial

from ogacq_drivers.errors import (
    DeviceBusy,
    DeviceTimeout,
    DriverError,
    FrameError,
    LinkError,
    UnitError,
)

try:  # termios.error is not an OSError, and pyserial lets it escape from tcflush
    import termios

    _LINK_FAILURES: tuple[type[BaseException], ...] = (OSError, termios.error)
except ImportError:  # pragma: no cover - Windows
    termios = None  # type: ignore[assignment]
    _LINK_FAILURES = (OSError,)

log = logging.getLogger(__name__)
T = TypeVar("T")

Unit = Literal["mm", "inch"]
UNITS: tuple[Unit, ...] = ("mm", "inch")
MM_PER_INCH = Decimal("25.4")

_TERMINATORS = frozenset(b"\r\n")
_MAX_FRAME_BYTES = 64

# Longest a low-level read blocks before the driver re-checks its deadline; a
# read returns as soon as a byte arrives, so this wastes no line time.
POLL_S = 0.02

# Decimal places a gauge shows, by display unit. The sets do not overlap, so a
# gauge switched to inch (0.0001 in / 0.00005 in) cannot pass as a mm gauge at
# 0.001 mm or coarser. A 0.0001 mm gauge needs ``decimals=4`` spelled out.
DEFAULT_DECIMALS: dict[str, frozenset[int]] = {"mm": frozenset({1, 2, 3}),
                                               "inch": frozenset({4, 5})}


@dataclass(frozen=True, slots=True)
class Reading:
    """One value read from a gauge.

    ``value_mm`` is always in mm; ``unit`` is the unit the gauge displayed in
    (from the frame, or the configured unit when the frame has none); ``frame``
    is the raw bytes as received, kept for the record."""

    value_mm: float
    frame: bytes
    time_s: float  # wall clock (time.time()) when the frame was complete
    channel: str = ""
    unit: Unit = "mm"
    where: str = ""


@dataclass(frozen=True, slots=True)
class StableReading:
    """N consecutive readings that agree within the tolerance."""

    value_mm: float  # mean of the agreeing readings
    spread_mm: float  # max - min of the agreeing readings
    readings: tuple[Reading, ...]

    @property
    def where(self) -> str:
        return self.readings[-1].where

    @property
    def channel(self) -> str:
        return self.readings[-1].channel

    @property
    def time_s(self) -> float:
        return self.readings[-1].time_s


@runtime_checkable
class Indicator(Protocol):
    """What every indicator driver offers.

    ``read`` returns one value. Request/response drivers (01A, Sylvac, polled
    Digimatic) flush stale input before each request, so a read is always
    fresh. Free-running sources (streaming Digimatic bridge, U-WAVE receiver)
    return frames in arrival order, so consecutive reads see consecutive
    frames; ``flush_input`` drops what arrived before now, and
    :func:`read_stable` calls it first."""

    where: str

    def read(self, timeout_s: float | None = None) -> Reading: ...

    def flush_input(self) -> None: ...

    def close(self) -> None: ...


def check_unit(unit: str | None, *, where: str) -> Unit:
    """Validate a configured unit (``"mm"`` or ``"inch"``)."""
    if unit == "mm":
        return "mm"
    if unit == "inch":
        return "inch"
    raise UnitError(f"unit must be 'mm' or 'inch', got {unit!r}", where=where)


def accepted_decimals(unit: Unit, decimals: int | Iterable[int] | None, *,
                      where: str) -> frozenset[int]:
    """The decimal layouts accepted from a unit-less frame configured in ``unit``."""
    if decimals is None:
        return DEFAULT_DECIMALS[unit]
    chosen = frozenset([decimals] if isinstance(decimals, int) else decimals)
    if not chosen or any(not 0 <= d <= 7 for d in chosen):
        raise UnitError(f"decimals must be between 0 and 7, got {sorted(chosen)}", where=where)
    other: Unit = "inch" if unit == "mm" else "mm"
    overlap = chosen & DEFAULT_DECIMALS[other]
    if overlap:
        log.warning("%s: configured %s with %s decimals, a layout an %s display also uses: "
                    "a gauge switched to %s would not be detected",
                    where, unit, sorted(overlap), other, other)
    return chosen


def check_decimals(decimals: int, unit: Unit, accepted: frozenset[int], *, where: str,
                   frame: bytes) -> None:
    """Refuse a frame whose decimal layout contradicts the configured unit."""
    if decimals in accepted:
        return
    looks_like: Unit = "inch" if decimals in DEFAULT_DECIMALS["inch"] else "mm"
    raise UnitError(f"frame shows {decimals} decimals but the gauge is configured in {unit} "
                    f"(expects {sorted(accepted)} decimals); the gauge display is probably in "
                    f"{looks_like}: set it back to {unit} or correct the configuration",
                    where=where)


def reading_of(value: Decimal, unit: Unit, frame: bytes, *, channel: str,
               where: str) -> Reading:
    """The reading of a decoded frame's value, displayed in ``unit``, stamped now."""
    return Reading(value_mm=to_mm(value, unit), frame=frame, time_s=time.time(),
                   channel=channel, unit=unit, where=where)


def warn_other_unit(shown: Unit, configured: Unit, *, where: str) -> None:
    """Said once a frame carrying its unit shows another than the configured one."""
    if shown != configured:
        log.warning("%s: gauge displays %s but is configured %s; values are converted "
                    "from the unit in each frame", where, shown, configured)


def to_mm(value: Decimal, unit: Unit) -> float:
    """A displayed value in mm (exact decimal arithmetic, one rounding at the end)."""
    mm = value * MM_PER_INCH if unit == "inch" else value
    return float(mm) + 0.0  # + 0.0 turns -0.0 into 0.0


# What a byte received with a parity or framing error (or a break) is read as once
# flag_line_errors() has set the port up: termios(3), "If neither IGNPAR nor PARMRK is
# set, read a character with a parity error or framing error as \0". No frame of any
# gauge protocol here has a NUL in it.
LINE_ERROR_BYTE = 0


def flag_line_errors(link: serial.Serial, *, where: str) -> bool:
    """Have the kernel read a byte received with a parity or framing error as NUL.

    pyserial (3.5, serialposix ``_reconfigure_port``) clears INPCK each time it
    configures a port, and Linux then passes such a byte on as if it were good (n_tty
    ``n_tty_receive_parity_error``; the 8250 UART driver does not even look for
    parity and framing errors without INPCK): the 7E2 parity of a Sylvac line guarded
    nothing, and a wrong baud rate gave plausible characters. Setting INPCK (IGNPAR and
    PARMRK clear) turns each such byte into a NUL, which no frame grammar accepts.
    Links without a terminal (``socket://``, ``loop://``, ``rfc2217://``, Windows) are
    left alone. Returns whether the port is a terminal set so."""
    fd = getattr(link, "fd", None)
    if termios is None or not isinstance(fd, int) or fd < 0 or not os.isatty(fd):
        return False
    with link_errors(where, "setting up parity and framing checks"):
        attributes = termios.tcgetattr(fd)
        iflag = attributes[0]
        wanted = (iflag | termios.INPCK) & ~(termios.IGNPAR | termios.PARMRK)
        if wanted != iflag:
            attributes[0] = wanted
            termios.tcsetattr(fd, termios.TCSANOW, attributes)
    return True


def refuse_line_errors(frame: bytes, *, where: str) -> bytes:
    """``frame`` unless it holds a byte the kernel flagged (:func:`flag_line_errors`)."""
    if LINE_ERROR_BYTE in frame:
        raise FrameError("a byte arrived with a parity or framing error (read as NUL): check "
                         "the line settings (baud rate, data bits, parity, stop bits) against "
                         "the gauge's and the cable; a break (cable plugged in or powered up) "
                         "reads the same", where=where, frame=frame)
    return frame


@contextmanager
def link_errors(where: str, action: str) -> Iterator[None]:
    """Turn transport failures (pyserial, OS, termios) into :class:`LinkError`."""
    try:
        yield
    except _LINK_FAILURES as exc:
        raise LinkError(f"link lost while {action} ({exc}); was the gauge or adapter "
                        "unplugged?", where=where) from exc


class IndicatorDriver:
    """What every indicator driver shares: the ``where`` its errors name, its read
    deadline, and being closed at the end of a ``with`` block."""

    #: Reply deadline when ``read`` is given none.
    default_timeout_s: float = 1.0

    def __init__(self, *, where: str, timeout_s: float | None) -> None:
        self.where = where
        self.timeout_s = self.default_timeout_s if timeout_s is None else timeout_s

    def close(self) -> None:
        raise NotImplementedError

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"{type(self).__name__}(where={self.where!r})"

    def _deadline(self, timeout_s: float | None) -> float:
        return time.monotonic() + (self.timeout_s if timeout_s is None else timeout_s)

    def _set_unit(self, unit: str, decimals: int | Iterable[int] | None) -> None:
        """The unit set on the gauge (recorded at setup), and the decimal layouts a frame
        without a unit field may show in it (:func:`accepted_decimals`)."""
        self.unit: Unit = check_unit(unit, where=self.where)
        self._accepted_decimals = accepted_decimals(self.unit, decimals, where=self.where)

    def _checked(self, value: Decimal, decimals: int, frame: bytes, channel: str) -> Reading:
        """The reading of a decoded frame whose decimals must fit the configured unit (the
        frame itself carries none), stamped now."""
        check_decimals(decimals, self.unit, self._accepted_decimals, where=self.where,
                       frame=frame)
        return reading_of(value, self.unit, frame, channel=channel, where=self.where)


class SerialIndicator(IndicatorDriver):
    """Shared plumbing of the serial indicator drivers.

    The driver receives an open link (it never opens one) and a ``where`` name
    used in every error. ``owns_link`` says whether :meth:`close` closes it.
    Frames are read terminator-delimited against a deadline, never by a
    fixed-length read: bytes are read as they arrive, and bytes after a
    terminator are kept for the next frame. Empty segments (the LF of a CR LF
    pair) are skipped. Every transport failure becomes a :class:`LinkError`."""

    def __init__(self, link: serial.Serial, *, where: str, timeout_s: float | None = None,
                 owns_link: bool = False) -> None:
        super().__init__(where=where, timeout_s=timeout_s)
        self.link = link
        self.owns_link = owns_link
        if link.timeout is None or link.timeout == 0 or link.timeout > 0.1:
            # Reads block at most link.timeout between deadline checks: a
            # blocking (or busy-polling) link would ignore our deadlines.
            log.debug("%s: link timeout %r -> %s s", where, link.timeout, POLL_S)
            with link_errors(where, "configuring the link"):
                link.timeout = POLL_S
        # After the timeout above: pyserial clears INPCK whenever it reconfigures.
        self._flags_line_errors = flag_line_errors(link, where=where)
        self._buffer = bytearray()
        self._cut_by_flush = False  # set by drivers of pushed streams when they flush

    def flush_input(self) -> None:
        """Discard whatever the gauge sent before now (and set the port to flag line
        errors again, should anything have reconfigured it since)."""
        if self._flags_line_errors:
            flag_line_errors(self.link, where=self.where)
        self._buffer.clear()
        with link_errors(self.where, "flushing input"):
            self.link.reset_input_buffer()

    def close(self) -> None:
        """Close the link if this driver opened it (through the factory)."""
        if self.owns_link:
            self.link.close()

    def _send(self, data: bytes) -> None:
        # No flush() (tcdrain): write() already hands the bytes to the driver,
        # and waiting for them to leave the UART would only add latency.
        with link_errors(self.where, "writing"):
            self.link.write(data)

    def _read_frame(self, deadline: float) -> bytes:
        """The next frame including its terminator, unless it holds a byte the kernel
        flagged (:func:`flag_line_errors`); DeviceTimeout at ``deadline`` (a
        ``time.monotonic()`` value)."""
        while True:
            frame = self._take_frame()
            if frame is not None:
                return refuse_line_errors(frame, where=self.where)
            with link_errors(self.where, "reading"):
                waiting = self.link.in_waiting
                # Bytes already here are used even at the deadline.
                if not waiting and time.monotonic() >= deadline:
                    break
                # All waiting bytes at once; otherwise block for one byte,
                # which returns as soon as it arrives.
                chunk = self.link.read(waiting or 1)
            self._buffer += chunk
        partial = bytes(self._buffer)
        self._buffer.clear()
        if partial:
            raise DeviceTimeout(f"incomplete frame at the deadline, got {partial!r}",
                                where=self.where)
        raise DeviceTimeout("no reply before the deadline", where=self.where)

    def _take_frame(self) -> bytes | None:
        buffer = self._buffer
        start = 0
        while start < len(buffer) and buffer[start] in _TERMINATORS:
            start += 1
        if start:
            del buffer[:start]
        for index, byte in enumerate(buffer):
            if byte in _TERMINATORS:
                frame = bytes(buffer[: index + 1])
                del buffer[: index + 1]
                return frame
        if len(buffer) > _MAX_FRAME_BYTES:
            junk = bytes(buffer)
            buffer.clear()
            raise FrameError(f"no terminator within {_MAX_FRAME_BYTES} bytes", where=self.where,
                             frame=junk)
        return None

    def _read_decoded(self, deadline: float, decode: Callable[..., T]) -> tuple[bytes, T]:
        """The next frame and what ``decode`` makes of it. On a line the device
        pushes frames onto, the first frame after a flush may be the tail of one the
        flush cut: that one is dropped, not reported as garbled."""
        while True:
            frame = self._read_frame(deadline)
            try:
                decoded = decode(frame, where=self.where)
            except FrameError:
                if self._cut_by_flush:
                    self._cut_by_flush = False
                    log.debug("%s: dropped a partial frame after flush: %r", self.where, frame)
                    continue
                raise
            self._cut_by_flush = False
            return frame, decoded


def read_stable(indicator: Indicator, n: int = 3, tolerance_mm: float = 0.002,
                timeout_s: float = 5.0) -> StableReading:
    """Flush stale input, then read until ``n`` consecutive values agree within
    ``tolerance_mm`` (max - min); return their mean.

    A garbled frame or a busy gauge breaks the run of consecutive values and
    reading goes on; other device errors (fault codes, unit, link) propagate at
    once. Raises :class:`DeviceTimeout` naming the gauge when the values never
    settle within ``timeout_s``."""
    if n < 1:
        raise ValueError(f"n must be at least 1, got {n}")
    if tolerance_mm < 0:
        raise ValueError(f"tolerance_mm must not be negative, got {tolerance_mm}")
    deadline = time.monotonic() + timeout_s
    indicator.flush_input()
    window: deque[Reading] = deque(maxlen=n)
    count = 0
    last_error: DriverError | None = None
    spread_mm = float("nan")
    while True:
        remaining = deadline - time.monotonic()
        try:
            if remaining <= 0:
                raise DeviceTimeout("deadline reached", where=indicator.where)
            reading = indicator.read(timeout_s=remaining)
        except (FrameError, DeviceBusy) as exc:
            log.warning("%s: discarding a reading while waiting for stability: %s",
                        indicator.where, exc)
            last_error = exc
            window.clear()
            continue
        except DeviceTimeout as exc:
            if count == 0 and last_error is None:
                raise
            detail = (f"last {len(window)} values spread {spread_mm:.6g} mm" if window
                      else "no consecutive values")
            if last_error is not None:
                detail += f"; last error: {last_error}"
            raise DeviceTimeout(f"readings did not settle within {timeout_s:g} s ({count} "
                                f"readings, {detail}, needed {n} within {tolerance_mm:g} mm)",
                                where=indicator.where) from exc
        count += 1
        window.append(reading)
        values = [r.value_mm for r in window]
        spread_mm = max(values) - min(values)
        # The epsilon keeps quantised values (1.233, 1.235 at 0.002) from failing on float noise.
        if len(window) == n and spread_mm <= tolerance_mm + 1e-9:
            return StableReading(value_mm=sum(values) / n, spread_mm=spread_mm,
                                 readings=tuple(window))
