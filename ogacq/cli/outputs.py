"""Where a command will write, checked before it starts work: a wrong path is one
line and exit 2, not a traceback after a minute of fitting."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Annotated

import typer

from ogacq.errors import InputError

ForceOption = Annotated[bool, typer.Option(
    "--force", help="Overwrite the output file when it exists.")]


def check_new_file(path: Path, name: str) -> None:
    """Refuse a file to create (``name``: its option or argument) that exists, or
    whose folder is missing or cannot be written to."""
    if path.exists():
        raise InputError(path, "exists; not overwriting it")
    _check_file_folder(path, name)


def check_output_file(path: Path, name: str, *, force: bool) -> None:
    """As :func:`check_new_file`, but an existing file is replaced with ``force``."""
    if path.is_dir():
        raise InputError(path, f"is a folder; choose another {name}")
    if path.exists() and not force:
        raise InputError(path, "exists; not overwriting it without --force")
    _check_file_folder(path, name)


def _check_file_folder(path: Path, name: str) -> None:
    if not path.parent.is_dir():
        raise InputError(path, f"cannot be written: there is no folder {path.parent}; "
                         f"choose another {name}")
    _check_can_create_in(path.parent, path, name)


def check_output_folder(folder: Path, name: str) -> None:
    """Refuse a folder to write into (made when missing) that is a file, or that
    cannot be made or written to."""
    if folder.exists() and not folder.is_dir():
        raise InputError(folder, f"exists and is not a folder; choose another {name}")
    nearest = next(p for p in (folder, *folder.parents) if p.exists())
    if not nearest.is_dir():
        raise InputError(folder, f"cannot be made: {nearest} is not a folder; "
                         f"choose another {name}")
    _check_can_create_in(nearest, folder, name)


def _check_can_create_in(folder: Path, target: Path, name: str) -> None:
    # Creating a file is the only sure test: permission bits say nothing to root,
    # and /proc or a read-only mount refuse whatever the bits say.
    probe = folder / f".ogacq-write-test-{os.getpid()}"
    try:
        os.close(os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600))
        probe.unlink()
    except OSError as exc:
        raise InputError(target, f"cannot be written: {folder} refuses new files "
                         f"({exc.strerror or exc}); choose another {name}") from None
