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
