"""The one line on stderr that every error of ``ogacq`` comes down to, and the quiet
end when the reader of its output has left."""

from __future__ import annotations

import os
import select
import stat
import sys

from ogacq.cli.plain import plain


def say(kind: str, message: str) -> None:
    """One line on stderr, whatever line breaks or control characters the message had
    (it may quote a recorded name, a file's line or a device's reply); on a terminal,
    that line wrapped at its width between words (the terminal would cut a word)."""
    text = " ".join(part.strip() for part in message.splitlines() if part.strip())
    line = f"ogacq: {kind}: {plain(text)}"
    if _is_terminal(sys.stderr):
        from ogacq.cli.plain import console

        console(stderr=True, markup=False).print(line)
    else:
        print(line, file=sys.stderr, flush=True)


def _is_terminal(stream: object) -> bool:
    try:
        return bool(stream.isatty())  # type: ignore[attr-defined]
    except (AttributeError, ValueError):
        return False


# What a shell reports for a process its pipe's reader left, as `git log | head` does:
# nothing went wrong that the user needs to hear of. 128 + N for a command ended by
# signal N (bash(1), "EXIT STATUS"); SIGPIPE is 13 (signal(7)).
SIGPIPE_EXIT = 141


def reader_gone() -> bool:
    """Whether standard output's reader has left (``ogacq history | head``): the
    system marks the writing end of a pipe whose reading end closed with POLLERR
    (poll(2)), and a socket whose peer closed with POLLHUP. Then standard output is
    pointed at the null device, so that the interpreter's last flush finds nowhere to
    fail (Python's documentation, "Note on SIGPIPE")."""
    try:
        fd = sys.stdout.fileno()
        poller = select.poll()  # not on Windows, where a pipe has no SIGPIPE either
    except (AttributeError, OSError, ValueError):
        return False
    poller.register(fd, select.POLLOUT)
    if not any(events & (select.POLLERR | select.POLLHUP) for _, events in poller.poll(0)):
        return False
    os.dup2(os.open(os.devnull, os.O_WRONLY), fd)
    return True


def pointed_at_null_device() -> bool:
    """Whether standard output is the null device: where rich points it when the
    reader left (rich 14, ``Console.on_broken_pipe``), before its exit 1; click
    (8.x, ``Command.main``) exits 1 too, leaving standard output as it was."""
    try:
        here, null = os.fstat(sys.stdout.fileno()), os.stat(os.devnull)
    except (AttributeError, OSError, ValueError):
        return False
    return stat.S_ISCHR(here.st_mode) and here.st_rdev == null.st_rdev
