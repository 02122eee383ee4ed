"""The ``ogacq`` command: a command line run through typer's group
(``ogacq.cli.typer_app``: its help, completion and usage errors the same for every
command), and every error turned into one line and the exit code of its kind.
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


def _run(argv: list[str]) -> int:
    setup_now()  # the commands log from any module (drivers, pymodbus): at once
    from ogacq.cli.typer_app import run_app

    return run_app(argv)


def main(argv: list[str] | None = None) -> int:
    # Warnings on stderr, one line each: installed before the command runs (``_run``),
    # or by the first ogacq logger made before that (ogacq.logs).
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
    except OSError as exc:  # the disk's fault, not the user's input: as a StorageError
        # the reader of the output left: quiet; another pipe's (a device's): a fault
        if isinstance(exc, BrokenPipeError) and reader_gone():
            return SIGPIPE_EXIT
        say("error", _os_error(exc))
        return 3


def __getattr__(name: str) -> Any:
    """typer's group (``app``, ``OgacqCommands``), imported when asked for (after the
    BLAS setting above)."""
    if name in ("app", "OgacqCommands"):
        from ogacq.cli import typer_app

        return getattr(typer_app, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


if __name__ == "__main__":
    sys.exit(main())
