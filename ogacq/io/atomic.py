"""Replacing a file whole or not at all: a full disk, a read-only file system or a
crash mid-write leaves the old file (or none), never a truncated one."""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path

from ogacq.io.errors import StorageError


def write_atomically(path: str | Path, data: bytes) -> None:
    """Write ``data`` to a temporary file beside ``path``, force it to the disk, then
    rename it over ``path`` (rename is atomic on POSIX). Raises StorageError, with
    nothing left behind, when any step fails."""
    path = Path(path)
    tmp: str | None = None
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except OSError as exc:
        if tmp is not None:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
        raise StorageError(path, exc) from None
