"""Files written whole or not at all, their errors worded for the user: the writer
itself is ``ogacq_drivers.atomic``, the project's one (the simulator writes through it
too, and ``drivers`` never imports ``ogacq``)."""

from __future__ import annotations

from pathlib import Path

from ogacq_drivers import atomic
from ogacq_drivers.atomic import fsync_folder
from ogacq.io.errors import InputError, StorageError

__all__ = ["fsync_folder", "write_atomically", "write_new_file"]


def write_atomically(path: str | Path, data: bytes) -> None:
    """Replace ``path`` with ``data`` (see ``ogacq_drivers.atomic``); StorageError, with
    nothing left behind, when any step fails."""
    try:
        atomic.write_atomically(path, data)
    except OSError as exc:
        raise StorageError(Path(path), exc) from None


def write_new_file(path: str | Path, data: bytes) -> None:
    """Create ``path`` holding ``data``, never replacing a file: InputError when it
    exists, StorageError (with nothing left behind) when it cannot be written."""
    try:
        atomic.write_new_file(path, data)
    except FileExistsError:
        raise InputError(Path(path), "exists; not overwriting it") from None
    except OSError as exc:
        raise StorageError(Path(path), exc) from None
