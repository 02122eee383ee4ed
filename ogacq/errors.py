"""The project's exceptions, for ``ogacq`` code to import from one place.

The root and its branches live in ``ogacq_drivers.errors`` (``drivers`` never imports
``ogacq``); the command line maps the branches to exit codes (README, "Exit
codes"). Errors of one stage derive from a branch next to the code that raises
them: ``DiagnosisError`` is an ``InputError``, ``WriteBackError`` a
``DriverError``, ``CampaignStopped`` a stop of its own (exit 3, 130 when the
operator interrupted).
"""

from __future__ import annotations

from pathlib import Path

from ogacq_drivers.errors import DriverError, InputError, OgacqError, Refused

__all__ = ["DriverError", "InputError", "OgacqError", "Refused", "StorageError"]


class StorageError(OgacqError):
    """A file could not be written: the disk is full, the file system read-only or
    failing. A fault of the station's disk, not of the user's input: exit 3, and
    whatever was written before stays intact."""

    exit_code = 3

    def __init__(self, path: str | Path, cause: OSError, what: str = "write") -> None:
        self.path = str(path)
        self.cause = cause
        super().__init__(f"{self.path}: cannot {what} ({cause.strerror or cause})")
