"""The ``ogacq`` command: a command line run, and every error turned into one line
and the exit code of its kind.

A command marked ``fast`` in the table (refit, diagnose) with a command line the
fast path can vouch for runs without typer (``ogacq.cli.fast_path``: typer costs a
short analysis a third of its run); every other line goes to typer's group
(``ogacq.cli.typer_app``), whose help, completion and usage errors are the same for
all commands.
"""

from __future__ import annotations

import os
import sys
from typing import Any

# One BLAS thread unless the user says otherwise: the analyses solve many small
# systems, where starting and parking OpenBLAS's threads costs a command ~0.1 s of its
# start-up and gains nothing. Set before numpy is first imported (by a command).
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from ogacq.cli.command_table import EXIT_CODES  # noqa: E402
from ogacq.cli.fast_path import fast_call  # noqa: E402
from ogacq.cli.log_options import global_options_first  # noqa: E402
from ogacq.cli.say import SIGPIPE_EXIT, reader_gone, say  # noqa: E402
from ogacq.errors import OgacqError  # noqa: E402
from ogacq.logs import before_first_logger, setup_now  # noqa: E402

__all__ = ["EXIT_CODES", "main"]


def _os_error(exc: OSError) -> str:
    """A file the system refused (a full disk, a read-only folder, a permission) that
    no command turned into its own error: the file and the reason, in one line."""
    where = ": ".join(str(f) for f in (exc.filename, exc.filename2) if f is not None)
    return f"{where}: {exc.strerror or exc}" if where else str(exc.strerror or exc)


def _configure_logging() -> None:
    from ogacq.cli.repeated_warnings import configure_logging

    configure_logging()


def _say_pending_repeats() -> None:
    """The count of a warning still being repeated, if anything could log."""
    if "logging" in sys.modules:  # else nothing made a logger, nor a handler
        from ogacq.cli.repeated_warnings import say_pending_repeats

        say_pending_repeats()


def _run(argv: list[str]) -> int:
    call = fast_call(argv)
    if call is None:
        setup_now()  # typer's commands log from any module (drivers, pymodbus): at once
        from ogacq.cli.typer_app import run_app

        return run_app(argv)
    try:
        call()
    finally:
        _say_pending_repeats()  # before the command's last word
    return 0


def main(argv: list[str] | None = None) -> int:
    # Warnings on stderr, one line each: installed when the first ogacq logger is made
    # (ogacq.logs), so that a refit or a diagnosis that logs nothing never imports
    # logging; at once for every other command (``_run``).
    before_first_logger(_configure_logging)
    argv = global_options_first(sys.argv[1:] if argv is None else list(argv))
    try:
        return _run(argv)
    except OgacqError as exc:
        say(exc.label, str(exc))
        return exc.exit_code
    except KeyboardInterrupt:
        print("ogacq: interrupted", file=sys.stderr, flush=True)
        return 130
    except BrokenPipeError as exc:
        if not reader_gone():  # another pipe (a device's): a fault like any other
            say("error", _os_error(exc))
            return 3
        return SIGPIPE_EXIT
    except OSError as exc:  # the disk's fault, not the user's input: as a StorageError
        say("error", _os_error(exc))
        return 3


def __getattr__(name: str) -> Any:
    """typer's group (``app``, ``OgacqCommands``), imported when asked for: a command
    that runs on the fast path never loads typer."""
    if name in ("app", "OgacqCommands"):
        from ogacq.cli import typer_app

        return getattr(typer_app, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


if __name__ == "__main__":
    sys.exit(main())
