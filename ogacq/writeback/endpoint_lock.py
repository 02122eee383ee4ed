"""One lock per controller endpoint, and per maps file, for whatever moves or writes
them: a campaign, ``offsets write|restore``, ``maps restore``, ``calibrate``.

The session's own lock (``ogacq.session.store.SessionLock``) keeps two writers off one
session; it did not keep ``offsets write`` of one session from re-homing a controller
a campaign of another session was running on, nor ``maps restore`` from replacing the
maps a running campaign applies. Each drive (its link's endpoint, host:port or the
serial device's real path, and its unit id) and each maps file (its real path) has a
lock file in a folder shared by the station's processes; an ``flock`` on it is held
while the controller is open, so it goes with the process, however it ends. The lock
file names its holder for the refusal another process gets. Within one process the
locks are counted, not taken twice (a procedure opens the controller step by step).
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import os
import re
import sys
import tempfile
import time
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path

from ogacq.errors import InputError

LOCK_DIR_ENV = "OGACQ_LOCK_DIR"  # tests and stations that keep /tmp private per service

_held: dict[str, tuple[int, int]] = {}  # key -> (file descriptor, holders in this process)


def lock_folder() -> Path:
    given = os.environ.get(LOCK_DIR_ENV)
    folder = Path(given) if given else Path(tempfile.gettempdir()) / "ogacq-locks"
    if not folder.is_dir():
        folder.mkdir(parents=True, exist_ok=True)
        with contextlib.suppress(OSError):  # shared by every user of the station
            folder.chmod(0o1777)
    return folder


def endpoint(port: str) -> str:
    """The endpoint as one name whatever it was written as: a serial device by its real
    path (/dev/serial/by-id/... is /dev/ttyUSB0), a host in lower case."""
    if port.startswith("/") or os.path.exists(port):
        return os.path.realpath(port)
    return port.strip().lower().replace("localhost:", "127.0.0.1:")


def controller_keys(ports: Mapping[str, str], units: Mapping[str, int]) -> list[str]:
    """The drives of a controller: each axis's endpoint and unit id."""
    return sorted({f"drive {endpoint(ports[a])} unit {units[a]}" for a in ports})


def maps_key(path: str | Path) -> str:
    return f"maps file {os.path.realpath(path)}"


@contextlib.contextmanager
def holding(keys: Iterable[str]) -> Iterator[None]:
    """Hold every lock of ``keys`` (in sorted order: two processes never wait on each
    other); InputError naming the holder of the first one held elsewhere."""
    taken: list[str] = []
    try:
        for key in sorted(set(keys)):
            _acquire(key)
            taken.append(key)
        yield
    finally:
        for key in reversed(taken):
            _release(key)


def _path(key: str) -> Path:
    slug = re.sub(r"[^A-Za-z0-9._-]+", "_", key)[-60:]
    return lock_folder() / f"{hashlib.sha256(key.encode()).hexdigest()[:16]}-{slug}.lock"


def _acquire(key: str) -> None:
    if key in _held:
        fd, count = _held[key]
        _held[key] = (fd, count + 1)
        return
    fd = os.open(_path(key), os.O_RDWR | os.O_CREAT, 0o666)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        holder = _holder(fd)
        os.close(fd)
        raise InputError(key, f"in use by {holder}: one process at a time moves or writes "
                         "a controller and its maps; wait until it has finished") from None
    with contextlib.suppress(OSError):  # only a refusal's message depends on it
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{' '.join(['ogacq', *sys.argv[1:3]])} (pid {os.getpid()}) since "
                      f"{time.strftime('%H:%M:%S')}\n".encode(), 0)
    _held[key] = (fd, 1)


def _holder(fd: int) -> str:
    try:
        note = os.pread(fd, 400, 0).decode("utf-8", "replace").strip()
    except OSError:
        return "another process"
    return note.splitlines()[0][:200] if note else "another process"


def _release(key: str) -> None:
    fd, count = _held[key]
    if count > 1:
        _held[key] = (fd, count - 1)
        return
    del _held[key]
    with contextlib.suppress(OSError):
        os.ftruncate(fd, 0)
    os.close(fd)  # closing the last descriptor releases the flock
