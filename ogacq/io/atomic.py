"""Writing a file whole or not at all: a full disk, a read-only file system or a
crash mid-write leaves the old file (or none), never a truncated one, and nothing
in the way of a retry."""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path

from ogacq.io.errors import InputError, StorageError

NEW_FILE_MODE = 0o644  # what the files a user reads and edits get (sessions too)


def write_atomically(path: str | Path, data: bytes) -> None:
    """Write ``data`` to a temporary file beside ``path``, force it to the disk, then
    rename it over ``path`` (rename is atomic on POSIX). Raises StorageError, with
    nothing left behind, when any step fails."""
    path = Path(path)
    tmp: str | None = None
    try:
        mode = path.stat().st_mode & 0o777 if path.is_file() else NEW_FILE_MODE
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, mode)  # the file it replaces keeps its mode; mkstemp's 0600 is its own
        os.replace(tmp, path)
    except OSError as exc:
        if tmp is not None:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
        raise StorageError(path, exc) from None


def write_new_file(path: str | Path, data: bytes) -> None:
    """Create ``path`` holding ``data``, whole or not at all, never replacing a file:
    InputError when ``path`` exists, StorageError (with nothing left behind) when it
    cannot be written. The data goes to a temporary file beside it first, then takes
    its name by a hard link, which fails rather than replace (a file system without
    hard links gets a rename after a last check)."""
    path = Path(path)
    tmp: str | None = None
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, NEW_FILE_MODE)  # mkstemp's 0600 is for the temporary only
        try:
            os.link(tmp, path)
        except FileExistsError:
            raise
        except OSError:  # no hard links here (FAT): the last check, then the rename
            if path.exists():
                raise FileExistsError(17, "File exists", str(path)) from None
            os.rename(tmp, path)
            tmp = None
    except FileExistsError:
        raise InputError(path, "exists; not overwriting it") from None
    except OSError as exc:
        raise StorageError(path, exc) from None
    finally:
        if tmp is not None:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
