"""Warnings one line each, a repeat printed once then counted: a gauge sending garbage
warns thousands of times a failed reading. A repeat is the same up to its numbers."""

from __future__ import annotations

import logging
import re
import sys
from typing import Protocol

_NUMBER = re.compile(r"\d+")


class TextSink(Protocol):
    """Where a handler writes its lines: a text stream, or the wizard's screen."""

    def write(self, text: str, /) -> object: ...


class RepeatCollapsingHandler(logging.StreamHandler):
    """Prints a record unless it repeats the previous one (same logger, level and
    message up to its numbers); the count of repeats is printed as
    ``(repeated N times)`` when another warning comes, and when flushed or closed."""

    def __init__(self, stream: TextSink | None = None) -> None:
        super().__init__(stream if stream is not None else sys.stderr)
        self._last: tuple[str, int, str] | None = None
        self._repeats = 0

    def emit(self, record: logging.LogRecord) -> None:
        key = (record.name, record.levelno, _NUMBER.sub("#", record.getMessage()))
        if key == self._last:
            self._repeats += 1
            return
        self._say_repeats()
        self._last = key
        super().emit(record)

    def flush(self) -> None:
        self._say_repeats()
        super().flush()

    def _say_repeats(self) -> None:
        if self._repeats:
            repeats, self._repeats = self._repeats, 0
            self.stream.write(f"ogacq: (the warning above repeated {repeats} more "
                              f"time{'s' if repeats > 1 else ''})\n")


class OneLineFormatter(logging.Formatter):
    """``ogacq: warning: ...`` (or ``info``, ``error``): as the command's own messages."""

    def format(self, record: logging.LogRecord) -> str:
        return f"ogacq: {record.levelname.lower()}: {record.getMessage()}"


def configure_logging() -> None:
    """Warnings and errors on stderr, one line each, repeats counted (unless logging
    was configured already: a program embedding ``main`` keeps its own)."""
    handler = RepeatCollapsingHandler()
    handler.setFormatter(OneLineFormatter())
    logging.basicConfig(level=logging.WARNING, handlers=[handler])
    # pymodbus logs a refused connection too; our own one-line error names the device
    logging.getLogger("pymodbus").setLevel(logging.CRITICAL)


def say_pending_repeats() -> None:
    """The count of a warning still being repeated, before the command's last word."""
    for handler in logging.getLogger().handlers:
        if isinstance(handler, RepeatCollapsingHandler):
            handler.flush()
