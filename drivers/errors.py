"""One exception root for every instrument and controller driver.

Callers catch ``DriverError`` to handle any device problem; the subclasses say
what kind, so a campaign can decide whether to retry (``DeviceBusy``,
``DeviceTimeout``) or stop (``DeviceFault``, ``LinkError``).
"""

from __future__ import annotations


class DriverError(Exception):
    """Any failure talking to a gauge or a controller. ``where`` names the device."""

    def __init__(self, message: str, *, where: str = "") -> None:
        self.where = where
        super().__init__(f"{where}: {message}" if where else message)


class LinkError(DriverError):
    """The port or connection cannot be opened, or went away (unplugged, refused)."""


class DeviceTimeout(DriverError):
    """The device did not answer (or did not finish) within the deadline."""


class FrameError(DriverError):
    """Bytes arrived but do not match the frame grammar (garbled, truncated)."""

    def __init__(self, message: str, *, where: str = "", frame: bytes = b"") -> None:
        self.frame = frame
        super().__init__(f"{message} (frame {frame!r})" if frame else message, where=where)


class DeviceFault(DriverError):
    """The device answered with an error code of its own (``911``, ``ERR3``, an alarm)."""

    def __init__(self, message: str, *, code: str | int = "", where: str = "") -> None:
        self.code = code
        super().__init__(message, where=where)


class DeviceBusy(DeviceFault):
    """The device says it is busy (``918``): the request may be retried shortly."""


class UnitError(DriverError):
    """The device reports, or was set up with, a unit the caller did not expect."""
