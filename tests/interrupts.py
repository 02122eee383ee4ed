"""Children a test will interrupt, started as a terminal starts them.

A shell runs a background job (``cmd &``, ``trap '' INT``, a CI runner's job) with
SIGINT ignored, and an ignored signal stays ignored across fork and exec (POSIX
exec: "signals set to be ignored ... shall be set to be ignored by the new process
image"); Python then installs no KeyboardInterrupt handler in the child. A test that
sends SIGINT (a Ctrl-C) to a child started so would find it deaf, though an operator's
Ctrl-C at a terminal always reaches a process in the foreground. Children started
inside :func:`sigint_as_at_a_terminal` get SIGINT's default action whatever the
suite was started with.
"""

from __future__ import annotations

import signal
from collections.abc import Iterator
from contextlib import contextmanager


@contextmanager
def sigint_as_at_a_terminal() -> Iterator[None]:
    """Processes started inside do not inherit an ignored SIGINT. (A handler, unlike
    an ignored disposition, is reset to the default at exec.) Main thread only, as
    every ``signal.signal``."""
    if signal.getsignal(signal.SIGINT) is not signal.SIG_IGN:
        yield
        return
    signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
