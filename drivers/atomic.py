"""Writing a file whole or not at all: a full disk, a read-only file system or a
crash mid-write leaves the old file (or none), never a truncated one, and nothing
in the way of a retry. The one writer of the project: every file ogacq writes goes
through ``ogacq.io.atomic`` (which words its errors) and the simulator's files come
here directly; it lives in the drivers' ground layer because ``drivers`` never
imports ``ogacq``. ``tests/io/test_one_atomic_writer.py`` finds any other write in the
source.

The data reaches the disk before the file takes its name (fsync), and the name
itself after (an fsync of the folder: POSIX makes a rename durable only then, so a
power loss right after would otherwise leave the old file, or none).

The file gets the permissions a plain ``open()`` would give it (0666 less the umask;
those of the file it replaces, when there is one), not the temporary file's private
0600: a record is read by the reviewer who signs it, from another account."""

from __future__ import annotations

import contextlib
import os
from pathlib import Path


def _temporary_beside(path: Path, data: bytes, mode: int) -> str:
    """A temporary file beside ``path`` holding ``data`` on the disk; its name."""
    import tempfile  # here: a command that only reads does not pay for it (1 ms)

    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        os.fchmod(fd, mode)
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
    except OSError:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    return tmp


def write_atomically(path: str | Path, data: bytes) -> None:
    """Write ``data`` to a temporary file beside ``path``, force it to the disk, then
    rename it over ``path`` (rename is atomic on POSIX). OSError, with nothing left
    behind, when any step fails."""
    path = Path(path)
    tmp = _temporary_beside(path, data, _mode_for(path))
    try:
        os.replace(tmp, path)
    except OSError:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise
    fsync_folder(path.parent)


def write_new_file(path: str | Path, data: bytes) -> None:
    """Create ``path`` holding ``data``, whole or not at all, never replacing a file:
    FileExistsError when ``path`` exists, OSError (with nothing left behind) when it
    cannot be written. The data goes to a temporary file beside it first, then takes
    its name by a hard link, which fails rather than replace (a file system without
    hard links gets a rename after a last check)."""
    path = Path(path)
    tmp = _temporary_beside(path, data, 0o666 & ~_umask())
    try:
        os.link(tmp, path)
    except FileExistsError:
        raise
    except OSError:  # no hard links here (FAT): the last check, then the rename
        if path.exists():
            raise FileExistsError(17, "File exists", str(path)) from None
        os.rename(tmp, path)
    finally:
        with contextlib.suppress(OSError):  # gone after the rename: its name is the file's
            os.unlink(tmp)
    fsync_folder(path.parent)


def fsync_folder(folder: Path) -> None:
    """Make a rename or a new name in ``folder`` durable (POSIX: fsync of the folder);
    nothing where a folder cannot be opened or synced (some file systems refuse it,
    and the file's own data is on the disk already)."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        with contextlib.suppress(OSError):
            os.fsync(fd)
    finally:
        os.close(fd)


def _mode_for(path: Path) -> int:
    """The permissions of the file ``path`` names, or those a new file gets."""
    try:
        return path.stat().st_mode & 0o7777
    except OSError:
        return 0o666 & ~_umask()


def _umask() -> int:
    """The process's umask, read without changing it where Linux says it (setting it to
    read it back would race with another thread creating a file meanwhile)."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask
