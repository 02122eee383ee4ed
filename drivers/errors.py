"""One exception root for the project, and its three branches.

Every error the tool reports to a user derives from ``OgacqError``; the branch
says whose the problem is, and so the exit code the command line returns
(README, "Exit codes"):

* ``InputError`` (2): something the user gave -- a file, an option, a value.
* ``DriverError`` (3): a gauge or a controller failed or cannot be reached.
* ``Refused`` (4): the tool declines for safety or evidence reasons.

The root lives here, not in ``ogacq``, because ``drivers`` never imports ``ogacq``.

Callers catch ``DriverError`` to handle any device problem; its subclasses say
what kind, so a campaign can decide whether to retry (``DeviceBusy``,
``DeviceTimeout``) or stop (``DeviceFault``, ``LinkError``).
"""

from __future__ import annotations

from pathlib import Path


class OgacqError(Exception):
    """Any problem the tool reports in one line. ``label`` and ``exit_code`` are how
    the command line words and signals it."""

    label = "error"
    exit_code = 1


class InputError(OgacqError):
    """A problem in what the user gave: always the file (or the option), the line
    when there is one, and the problem in words. ``path`` is None when the problem
    names its own place."""

    exit_code = 2

    def __init__(self, path: str | Path | None, problem: str, line: int | None = None) -> None:
        self.path = None if path is None else str(path)
        self.line = line
        self.problem = problem
        where = f"{self.path}:{line}" if self.path is not None and line is not None else self.path
        super().__init__(f"{where}: {problem}" if where is not None else problem)


class Refused(OgacqError):
    """The tool declines to act (the evidence is unreliable, acting is unsafe);
    the message says what would make it go ahead."""

    label = "refused"
    exit_code = 4


class DriverError(OgacqError):
    """Any failure talking to a gauge or a controller. ``where`` names the device."""

    label = "device error"
    exit_code = 3

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


class PreflightError(DeviceFault):
    """The drive is not what its profile says (drivers/axes/preflight.py); names the
    profile field to change."""

    def __init__(self, message: str, *, field: str, where: str) -> None:
        super().__init__(message, code="preflight", where=where)
        self.field = field


class DeviceBusy(DeviceFault):
    """The device says it is busy (``918``): the request may be retried shortly."""


class UnitError(DriverError):
    """The device reports, or was set up with, a unit the caller did not expect."""
