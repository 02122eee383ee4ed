"""Errors in files a user gave us: always the file, the line when there is one,
and the problem in words."""

from __future__ import annotations

from pathlib import Path


class InputError(Exception):
    def __init__(self, path: str | Path, problem: str, line: int | None = None) -> None:
        self.path = str(path)
        self.line = line
        self.problem = problem
        where = f"{self.path}:{line}" if line is not None else self.path
        super().__init__(f"{where}: {problem}")


class StorageError(Exception):
    """A file could not be written: the disk is full, the file system read-only or
    failing. Reported in one line with exit 3 (a fault of the station's disk, not of
    the user's input); whatever was written before stays intact."""

    def __init__(self, path: str | Path, cause: OSError, what: str = "write") -> None:
        self.path = str(path)
        self.cause = cause
        super().__init__(f"{self.path}: cannot {what} ({cause.strerror or cause})")
