"""Campaign sessions: one append-only file of JSON records, one per line.

Every reading, move, prompt answer and event is written to the operating
system as it happens, so a crash, a Ctrl-C or a killed process loses nothing
that was measured; a background thread then forces each record to the disk
(fsync) within milliseconds, against a power cut, without holding the campaign
up for the disk's latency. The first record describes the session (machine, station,
plan, software version); the rest are appended in the order they happened. A
record cut by a crash mid-write (a torn last line) is dropped on loading with a
warning naming it; everything before it stands.

Each record proves itself (``ogacq.session.seal``): its sequence number, the
checksum of the line before it and its own CRC-32, checked on loading with the
fields its type must have. A record that cannot be read is named with its line;
one changed, removed, inserted or moved after it was written makes the session
*edited*, which an analysis refuses unless the user accepts it as it stands
(``accept_edited``: the loaded session then says so); a line written twice is
dropped with a warning; ``ogacq session salvage`` keeps every record as written
of a damaged file. Sessions written before the seals load as they are, and say
so.

One writer at a time, across processes: every writer holds an OS lock on the
session file (``flock``) for as long as it is open, appends only (``O_APPEND``),
and, when it continues a session it has read, first checks that nobody has
written to it since. Who holds the lock is said in ``SESSION.lock``.
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import shutil
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

from ogacq_drivers.threads import leave_interrupts_to_the_main_thread
from ogacq import __version__
from ogacq.errors import Refused
from ogacq.io.atomic import write_atomically, write_new_file
from ogacq.io.errors import InputError, StorageError
from ogacq.io.text import strip_bom
from ogacq.session.header import SessionHeader
from ogacq.session.records import (
    FORMAT,
    EndRecord,
    ReadingRecord,
    Record,
    ResultRecord,
    ResumeRecord,
    SalvageRecord,
    record_from_json,
)
from ogacq.session.seal import (
    CLOSED,
    CLOSING_KEY,
    SEAL,
    Closure,
    Integrity,
    Scan,
    line_crc,
    parses,
    scan_session,
    seal_line,
)

__all__ = ["LoadedSession", "SessionEdited", "SessionLock", "SessionWriter", "check_writable",
           "load_session", "lock_holder", "salvage_session", "scan_session", "write_session"]

R = TypeVar("R", bound=Record)


@dataclass
class LoadedSession:
    path: Path
    header: SessionHeader  # the first line: machine, station, plan, software, ...
    records: list[Record]  # the rest, in the order written
    warnings: list[str] = field(default_factory=list)
    size_bytes: int = 0  # of the file as read: a writer checks nobody wrote since
    # the header's format, and the edits the user accepted (ogacq.session.seal)
    integrity: Integrity = field(default_factory=Integrity)
    # whether the file ends where its last writer closed it (ogacq.session.seal)
    closure: Closure = field(default_factory=lambda: Closure(False, False, 0))

    def of_type(self, kind: type[R]) -> list[R]:
        return [r for r in self.records if isinstance(r, kind)]

    @property
    def readings(self) -> list[ReadingRecord]:
        return self.of_type(ReadingRecord)

    def recorded(self) -> set[tuple[str, str]]:
        """(step id, gauge key) of every reading on file."""
        return {(r.step, r.gauge.key) for r in self.readings}

    @property
    def finished(self) -> bool:
        return any(r.status == "complete" for r in self.of_type(EndRecord))

    @property
    def result(self) -> ResultRecord | None:
        """The identification the campaign recorded when it finished, if it did."""
        results = self.of_type(ResultRecord)
        return results[-1] if results else None


class _Syncer(threading.Thread):
    """Forces written records to the disk soon after they are written. A failed
    fsync (an I/O error, a file system gone read-only) is kept for the writer to
    raise: the records may not have reached the disk."""

    def __init__(self, fd: int) -> None:
        super().__init__(name="session-fsync", daemon=True)
        self._fd = fd
        self._pending = threading.Event()
        self._closing = False
        self.error: OSError | None = None

    def poke(self) -> None:
        self._pending.set()

    def run(self) -> None:
        leave_interrupts_to_the_main_thread()
        while True:
            self._pending.wait()
            self._pending.clear()
            try:
                os.fsync(self._fd)
            except OSError as exc:
                self.error = self.error or exc
            if self._closing:
                return

    def finish(self) -> None:
        self._closing = True
        self._pending.set()
        self.join()


class SessionLock:
    """An exclusive OS lock on a session file, held by one writer; its holder is said
    in ``SESSION.lock`` for the refusal another writer gets."""

    def __init__(self, path: Path, fd: int) -> None:
        self.path = path
        self._fd = fd
        self._note = path.with_name(path.name + ".lock")
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise InputError(path, f"in use by {self.holder_of(path)}: one writer at a time; "
                             "wait until it has finished") from None
        with contextlib.suppress(StorageError):  # only a refusal's message depends on it
            write_atomically(self._note, f"{' '.join(['ogacq', *sys.argv[1:3]])} (pid "
                             f"{os.getpid()}) since {time.strftime('%H:%M:%S')}\n"
                             .encode())

    @staticmethod
    def holder_of(path: Path) -> str:
        """Who holds the lock on ``path``, as its holder said."""
        try:
            note = path.with_name(path.name + ".lock").read_text(encoding="utf-8").strip()
        except (OSError, UnicodeDecodeError):
            return "another process"
        return note.splitlines()[0][:200] if note else "another process"

    def release(self) -> None:
        with contextlib.suppress(OSError):
            self._note.unlink()
        fcntl.flock(self._fd, fcntl.LOCK_UN)


# Room a campaign needs on disk before it starts: its records are a few hundred bytes
# each, so this holds tens of thousands of readings with room to spare.
MIN_FREE_BYTES = 16 * 2**20


def check_writable(path: str | Path, *, resuming: bool = False) -> None:
    """Refuse, before anything moves, a session that could not be written: a new one
    where one exists, a folder that cannot be made or written to, a session file
    that is read-only, or a disk with less than ``MIN_FREE_BYTES`` free."""
    path = Path(path)
    if not resuming and path.exists():
        raise InputError(path, "a session already exists here; resume it with "
                         f"`ogacq resume {path}` or choose another name")
    folder = path.parent
    try:
        folder.mkdir(parents=True, exist_ok=True)
        probe = folder / f".ogacq-write-test-{os.getpid()}"
        fd = os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        try:
            os.write(fd, b"\n")
        finally:
            os.close(fd)
            probe.unlink()
        if resuming and not os.access(path, os.W_OK):
            raise PermissionError(13, "the session file is read-only")
        free = shutil.disk_usage(folder).free
    except OSError as exc:
        raise InputError(path, f"cannot write the session here ({exc.strerror or exc}): "
                         "nothing was started") from None
    if resuming:
        _check_not_in_use(path)
    if free < MIN_FREE_BYTES:
        raise InputError(path, f"only {free / 2**20:.1f} MiB free on this disk, less than the "
                         f"{MIN_FREE_BYTES / 2**20:.0f} MiB a campaign needs: nothing was started")


def _check_not_in_use(path: Path) -> None:
    """Refuse, naming the holder, a session another writer holds now (the writer
    that opens it later takes the lock for good; this only refuses early)."""
    holder = lock_holder(path)
    if holder is not None:
        raise InputError(path, f"in use by {holder}: one writer at a time; wait until it has "
                         "finished")


class SessionWriter:
    """Appends records durably, each sealed (``ogacq.session.seal``). Opened on a new
    file (``create``) or to continue one (``append_to``).

    A record that cannot be written (disk full, file system read-only, I/O error)
    raises StorageError after the file is cut back to its last whole record, so
    what was recorded before stays valid and the session can be resumed once the
    disk is fixed."""

    def __init__(self, path: Path, fd: int, next_seq: int, lock: SessionLock | None = None, *,
                 prev: str | None = None, chained: bool = True, closing: bool = True) -> None:
        self.path = path
        self._lock = lock or SessionLock(path, fd)
        self._fd = fd
        self._closed = False
        self._size = os.fstat(fd).st_size  # bytes of whole records on file
        self._seq = next_seq
        # the chain checksum of the last line; a session written before the chain
        # (its header has no seal) goes on without one, as its records were written
        self._prev = prev
        self._chained = chained
        self._closing = closing  # the header announces a closed record at each close
        self._syncer = _Syncer(fd)
        self._syncer.start()

    @classmethod
    def create(cls, path: str | Path, header: dict[str, Any]) -> SessionWriter:
        path = Path(path)
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_APPEND, 0o644)
        except FileExistsError:
            raise InputError(path, "a session already exists here; resume it with "
                             f"`ogacq resume {path}` or choose another name") from None
        except OSError as exc:
            raise StorageError(path, exc, "create the session") from None
        writer = cls(path, fd, 0)
        writer._write(new_header(header))
        return writer

    @classmethod
    def append_to(cls, path: str | Path, expected_size: int | None = None) -> SessionWriter:
        """A writer at the end of an existing session (``expected_size``: as it was read;
        a session written to since is refused). A torn last record is cut off
        (appending after it would corrupt the file); a complete one that only lost
        its newline gets it back. StorageError (exit 3) when the file cannot be
        written (a read-only file system or file): nothing was appended."""
        path = Path(path)
        try:
            fd = os.open(path, os.O_RDWR | os.O_APPEND)
        except FileNotFoundError:
            raise InputError(path, "no such session") from None
        except OSError as exc:
            raise StorageError(path, exc, "write to the session") from None
        try:
            lock = SessionLock(path, fd)
        except InputError:
            os.close(fd)
            raise
        try:
            raw = strip_bom(path.read_bytes())
            if expected_size is not None and len(raw) != expected_size:
                raise InputError(path, "was written to since it was read (another command); "
                                 "run this again")
            if raw and not raw.endswith(b"\n"):
                tail = raw[raw.rfind(b"\n") + 1:]
                if parses(tail):
                    os.write(fd, b"\n")
                    raw += b"\n"
                else:
                    os.ftruncate(fd, os.fstat(fd).st_size - len(tail))
                    raw = raw[:raw.rfind(b"\n") + 1]
        except OSError as exc:
            lock.release()
            os.close(fd)
            raise StorageError(path, exc, "write to the session") from None
        except BaseException:
            lock.release()
            os.close(fd)
            raise
        lines = [line for line in raw.split(b"\n") if line.strip()]
        chained, closing = _header_seals(lines[0]) if lines else (True, True)
        return cls(path, fd, _next_seq(lines), lock,
                   prev=line_crc(lines[-1]) if lines and chained else None, chained=chained,
                   closing=closing)

    @classmethod
    def reopen(cls, session: LoadedSession) -> SessionWriter:
        """Append to a session to resume its campaign; the resume is recorded."""
        writer = cls.append_to(session.path, session.size_bytes or None)
        writer.write(ResumeRecord(software=f"ogacq {__version__}",
                                  after_records=len(session.records)))
        return writer

    def write(self, record: Record) -> None:
        self._write(_stamped(record, round(time.time(), 3)))

    def _write(self, record: dict[str, Any]) -> None:
        # The whole line into the OS at once: a killed process cannot lose it after
        # this; the syncer puts it on the disk.
        data = seal_line(record, self._seq, self._prev if self._chained else None)
        try:
            self._raise_sync_error()
            written = 0
            while written < len(data):  # a nearly full disk may take part of it
                written += os.write(self._fd, data[written:])
        except OSError as exc:
            self._cut_back()
            raise StorageError(self.path, exc, "write the session") from None
        self._size += len(data)
        self._seq += 1
        self._prev = line_crc(data)
        self._syncer.poke()

    def sync(self) -> None:
        """Force what is written to the disk now (an audit record that must be on
        the disk before the controller is touched); StorageError when it cannot."""
        try:
            self._raise_sync_error()
            os.fsync(self._fd)
        except OSError as exc:
            raise StorageError(self.path, exc, "write the session") from None

    def _raise_sync_error(self) -> None:
        if self._syncer.error is not None:
            error, self._syncer.error = self._syncer.error, None
            raise error

    def _cut_back(self) -> None:
        """Remove the part of a record a failed write left: the file ends with a whole
        record again (a torn line followed by a later record would be corruption)."""
        with contextlib.suppress(OSError):  # a read-only file system keeps it: torn, last
            os.ftruncate(self._fd, self._size)

    def close(self) -> None:
        """End this writer's turn with a ``closed`` record (where the header announces
        one) and release the session; a record or a last fsync that fails raises
        StorageError after it is released."""
        if self._closed:
            return
        self._closed = True
        if self._closing and self._syncer.error is None:
            # a record that cannot be written (a full disk) leaves the session saying it
            # is not closed; what was recorded before stands
            with contextlib.suppress(StorageError):
                self._write({"type": CLOSED, "wall": round(time.time(), 3)})
        self._syncer.finish()  # the last fsync, before the file is closed
        self._lock.release()
        os.close(self._fd)
        if self._syncer.error is not None:
            raise StorageError(self.path, self._syncer.error, "write the session")

    def __enter__(self) -> SessionWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _stamped(record: Record, wall: float) -> dict[str, Any]:
    """``record``'s line, ``wall`` its time unless it has one."""
    line = record.to_json()
    return {"type": line.pop("type"), "wall": line.pop("wall", wall), **line}


def new_header(header: dict[str, Any]) -> dict[str, Any]:
    """A new session's first record: its format, seal, software and creation time, then
    ``header`` (machine, station, plan, ...)."""
    given = {k: v for k, v in header.items()
             if k not in ("type", "format", "integrity", CLOSING_KEY)}
    return {"type": "session", "format": FORMAT, "integrity": SEAL, CLOSING_KEY: CLOSED,
            "software": f"ogacq {__version__}",
            "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"), **given}


def _header_seals(line: bytes) -> tuple[bool, bool]:
    """Whether a session's first line says its records are chained, and whether it
    announces a closed record at the end of each writer's turn."""
    try:
        first = json.loads(line)  # the raw line: its keys as written, before any typing
    except ValueError:
        return True, False
    if not isinstance(first, dict):
        return True, False
    return "integrity" in first, first.get(CLOSING_KEY) == CLOSED


def _next_seq(lines: list[bytes]) -> int:
    """The sequence number after the last line's (its count when that has none)."""
    if lines:
        try:
            seq = json.loads(lines[-1]).get("seq")
        except (ValueError, AttributeError):
            seq = None
        if isinstance(seq, int) and not isinstance(seq, bool):
            return seq + 1
    return len(lines)


def sealed_bytes(header: dict[str, Any], records: list[dict[str, Any]]) -> bytes:
    """A whole session as it is written: ``header`` (as written: give it
    :func:`new_header`'s) and ``records`` (each with its ``type`` and ``wall``),
    numbered and chained."""
    out: list[bytes] = []
    prev = None
    for seq, record in enumerate([header, *records]):
        line = seal_line(record, seq, prev)
        out.append(line)
        prev = line_crc(line)
    return b"".join(out)


def write_session(path: str | Path, header: dict[str, Any], records: list[Record]) -> Path:
    """A new session written whole or not at all (an import, a salvage): a full disk
    leaves no file in the way of a retry (StorageError), an existing file is refused."""
    path = Path(path)
    wall = round(time.time(), 3)
    lines = [*(_stamped(r, wall) for r in records), {"type": CLOSED, "wall": wall}]
    write_new_file(path, sealed_bytes(new_header(header), lines))
    return path


class SessionEdited(Refused):
    """A session whose records were changed, removed, inserted or moved after they were
    written: refused by every analysis unless accepted as it stands (exit 4)."""

    def __init__(self, path: Path, edited: list[tuple[int, str]]) -> None:
        self.path = str(path)
        self.edited = edited
        line, problem = edited[0]
        more = f" (and {len(edited) - 1} more)" if len(edited) > 1 else ""
        super().__init__(f"{path}:{line}: {problem}{more}: the session was edited after it was "
                         f"written; `ogacq session check {path}` lists every edit, --accept-edited "
                         "analyses it as it stands (every output then says so), `ogacq "
                         f"session salvage {path} NEW` keeps the records as written")


def load_session(path: str | Path, *, accept_edited: bool = False) -> LoadedSession:
    """The session at ``path``, every record checked. InputError when a line cannot be
    read or the file is no session; :class:`SessionEdited` when records were edited
    after they were written, unless ``accept_edited`` (the session then carries the
    edits in its ``integrity``)."""
    path = Path(path)
    scan = scan_session(path)
    if not scan.records or scan.records[0][0] != 1 or \
            scan.records[0][1].get("type") != "session":
        raise _not_a_session(path, scan)
    if scan.problems:
        number, problem = scan.problems[0]
        more = f" (and {len(scan.problems) - 1} more)" if len(scan.problems) > 1 else ""
        raise InputError(path, f"corrupt record: {problem}{more}; `ogacq session check` lists "
                         "every problem, `ogacq session salvage` keeps the valid records",
                         number)
    if scan.edited and not accept_edited:
        raise SessionEdited(path, scan.edited)
    first = scan.records[0][1]
    if first.get("format") != FORMAT:
        raise InputError(path, f"session format {first.get('format')!r} is not "
                         f"{FORMAT!r}", 1)
    return LoadedSession(path, SessionHeader.from_json(first),
                         [_typed(scan, n, r) for n, r in scan.records[1:]], scan.warnings,
                         scan.size_bytes, Integrity(scan.mode, tuple(scan.edited)), scan.closure)


def _typed(scan: Scan, number: int, content: dict[str, Any]) -> Record:
    """The record of line ``number``, typed as the scan found it (a second ``session``
    line, which the scan leaves as it is, typed here)."""
    record = scan.typed.get(number)
    return record_from_json(content) if record is None else record


def lock_holder(path: str | Path) -> str | None:
    """Who writes the session now (a campaign running, a write-back), or None. Probed
    with a shared lock, released at once: a reader never stops a writer starting."""
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except BlockingIOError:
            return SessionLock.holder_of(Path(path))
        except OSError:
            return None
        fcntl.flock(fd, fcntl.LOCK_UN)
        return None
    finally:
        os.close(fd)


def _not_a_session(path: Path, scan: Scan) -> InputError:
    """Why a file is not a session, said before anything about its later lines: a
    readings CSV given for a session is not a "corrupt record"."""
    first = [problem for line, problem in scan.problems if line == 1]
    if first and first[0].startswith("not valid JSON: "):  # says which byte
        why = f"line 1 is {first[0]}"
    elif (1, "not valid JSON") in scan.problems or not scan.size_bytes:
        why = "line 1 is not a JSON record"
    else:
        why = "no session header on line 1"
    return InputError(path, f"not an ogacq session ({why}); give the session.jsonl a "
                      "campaign wrote", 1)


def salvage_session(path: str | Path, out: str | Path) -> tuple[int, list[tuple[int, str]]]:
    """Write every record of ``path`` as it was written to the new session ``out``,
    renumbered and chained, with a last ``salvage`` record naming what was left out;
    returns (records kept, the lines left out and why). The new file is written whole
    or not at all: a full disk leaves nothing in the way of a retry."""
    scan = scan_session(path)
    kept = scan.untouched
    if not kept or kept[0][0] != 1 or kept[0][1].get("type") != "session":
        why = "is not as it was written" if 1 in scan.changed else "is not valid"
        raise InputError(path, f"the session header on line 1 {why}: nothing to salvage", 1)
    left_out = sorted(scan.problems + [e for e in scan.edited if e[0] in scan.changed])
    if len(kept) == 1:
        raise InputError(path, "no record beyond the header is as it was written: nothing to "
                         "salvage")
    given = kept[0][1]  # sealed again (an older session's header gains its seal)
    header: dict[str, Any] = {k: given[k] for k in ("type", "format") if k in given}
    header["integrity"] = SEAL
    header[CLOSING_KEY] = CLOSED
    header.update((k, v) for k, v in given.items()
                  if k not in ("type", "format", "integrity", CLOSING_KEY))
    records = [r for _, r in kept[1:]]
    wall = round(time.time(), 3)
    records.append(SalvageRecord(source=str(Path(path).resolve()), left_out=tuple(left_out),
                                 wall=wall).to_json())
    records.append({"type": CLOSED, "wall": wall})
    write_new_file(Path(out), sealed_bytes(header, records))
    return len(kept), left_out
