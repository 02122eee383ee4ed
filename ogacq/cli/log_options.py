"""``ogacq --verbose`` and ``ogacq --log-file FILE``: the terminal's warnings (with
info records too), and every record with its time into the file, for whoever
investigates a campaign afterwards."""

from __future__ import annotations

from pathlib import Path

from ogacq.errors import InputError
from ogacq.logs import setup_now

LOG_FILE_FORMAT = "%(asctime)s %(levelname)s %(name)s: %(message)s"


def apply_log_options(verbose: bool, log_file: Path | None) -> None:
    # logging imported here: the root options' names below are read by every command
    import logging

    from ogacq.cli.repeated_warnings import RepeatCollapsingHandler

    setup_now()  # the terminal's handler, whose level is set here
    root = logging.getLogger()
    terminal_level = logging.INFO if verbose else logging.WARNING
    for handler in root.handlers:
        if isinstance(handler, RepeatCollapsingHandler):
            handler.setLevel(terminal_level)
    root.setLevel(terminal_level)
    if log_file is None:
        return
    try:
        file_handler = logging.FileHandler(log_file, encoding="utf-8")
    except OSError as exc:
        raise InputError(log_file, f"cannot write the log file ({exc.strerror or exc})") \
            from None
    file_handler.setFormatter(logging.Formatter(LOG_FILE_FORMAT))
    file_handler.setLevel(logging.DEBUG)
    root.addHandler(file_handler)
    root.setLevel(logging.DEBUG)


# the root's own options: declared by typer_app's callback, parsed by the fast path
VERBOSE_FLAGS = ("--verbose", "-v")
LOG_FILE_OPTION = "--log-file"


def global_options_first(argv: list[str]) -> list[str]:
    """``ogacq run c.toml --log-file run.log`` as ``ogacq --log-file run.log run c.toml``:
    the global options are accepted after the command too (a user adds them at the end
    of the line they just ran). Nothing after ``--`` is touched."""
    front: list[str] = []
    rest: list[str] = []
    k = 0
    while k < len(argv):
        word = argv[k]
        if word == "--":
            rest += argv[k:]
            break
        if word in VERBOSE_FLAGS or word.startswith(f"{LOG_FILE_OPTION}="):
            front.append(word)
        elif word == LOG_FILE_OPTION and k + 1 < len(argv):
            front += argv[k:k + 2]
            k += 1
        else:
            rest.append(word)
        k += 1
    return front + rest
