"""Campaign sessions: one append-only file of JSON records, one per line.

Every reading, move, prompt answer and event is written to the operating
system as it happens, so a crash, a Ctrl-C or a killed process loses nothing
that was measured; a background thread then forces each record to the disk
(fsync) within milliseconds, against a power cut, without holding the campaign
up for the disk's latency. The first record describes the session (machine, station,
plan, software version); the rest are appended in the order they happened. A
record cut by a crash mid-write (a torn last line) is dropped on loading with a
warning naming it; everything before it stands.

Each record proves itself: it carries its sequence number and a CRC-32 of its
own line, and is checked on loading against the fields its type must have. A
record changed after it was written, out of sequence or missing what its type
needs is named with its line; a line written twice is dropped with a warning;
``ogacq session salvage`` keeps every valid record of a damaged file. Files
written before the sequence numbers and checksums load as they are.

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
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

from ogacq import __version__
from ogacq.io.errors import InputError, StorageError
from ogacq.io.text import strip_bom
from ogacq.session.records import (
    FORMAT,
    EndRecord,
    ReadingRecord,
    Record,
    ResultRecord,
    ResumeRecord,
    record_from_json,
)

R = TypeVar("R", bound=Record)


@dataclass
class LoadedSession:
    path: Path
    header: dict[str, Any]  # the first line: machine, station, plan, software, ...
    records: list[Record]  # the rest, in the order written
    warnings: list[str] = field(default_factory=list)
    size_bytes: int = 0  # of the file as read: a writer checks nobody wrote since

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
            raise InputError(path, f"in use by {self._holder()}: one writer at a time; "
                             "wait until it has finished") from None
        with contextlib.suppress(OSError):  # only a refusal's message depends on it
            self._note.write_text(f"{' '.join(['ogacq', *sys.argv[1:3]])} (pid {os.getpid()}) "
                                  f"since {time.strftime('%H:%M:%S')}\n", encoding="utf-8")

    def _holder(self) -> str:
        try:
            return self._note.read_text(encoding="utf-8").strip() or "another process"
        except OSError:
            return "another process"

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
    fd = os.open(path, os.O_RDONLY)
    try:
        SessionLock(path, fd).release()
    finally:
        os.close(fd)


def _line(record: dict[str, Any]) -> str:
    """The record as one line, its CRC-32 last (over the line without it)."""
    body = json.dumps(record, separators=(",", ":"))
    crc = zlib.crc32(body.encode("utf-8"))
    return f'{body[:-1]},"crc":"{crc:08x}"}}\n' if body != "{}" else body + "\n"


class SessionWriter:
    """Appends records durably. Opened on a new file (``create``) or to resume.

    A record that cannot be written (disk full, file system read-only, I/O error)
    raises StorageError after the file is cut back to its last whole record, so
    what was recorded before stays valid and the session can be resumed once the
    disk is fixed."""

    def __init__(self, path: Path, fd: int, next_seq: int,
                 lock: SessionLock | None = None) -> None:
        self.path = path
        self._lock = lock or SessionLock(path, fd)
        self._fd = fd
        self._closed = False
        self._size = os.fstat(fd).st_size  # bytes of whole records on file
        self._seq = next_seq
        self._syncer = _Syncer(fd)
        self._syncer.start()

    @classmethod
    def create(cls, path: str | Path, header: dict[str, Any]) -> SessionWriter:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        try:
            fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_APPEND, 0o644)
        except FileExistsError:
            raise InputError(path, "a session already exists here; resume it with "
                             f"`ogacq resume {path}` or choose another name") from None
        writer = cls(path, fd, 0)
        writer._write({"type": "session", "format": FORMAT, "software": f"ogacq {__version__}",
                       "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"), **header})
        return writer

    @classmethod
    def append_to(cls, path: str | Path, expected_size: int | None = None) -> SessionWriter:
        """A writer at the end of an existing session (``expected_size``: as it was read;
        a session written to since is refused). A torn last record is cut off
        (appending after it would corrupt the file); a complete one that only lost
        its newline gets it back."""
        path = Path(path)
        fd = os.open(path, os.O_RDWR | os.O_APPEND)
        try:
            lock = SessionLock(path, fd)
        except InputError:
            os.close(fd)
            raise
        try:
            raw = path.read_bytes()
            if expected_size is not None and len(raw) != expected_size:
                raise InputError(path, "was written to since it was read (another command); "
                                 "run this again")
            if raw and not raw.endswith(b"\n"):
                tail = raw[raw.rfind(b"\n") + 1:]
                if _parse(tail) is not None:
                    os.write(fd, b"\n")
                    raw += b"\n"
                else:
                    os.ftruncate(fd, raw.rfind(b"\n") + 1)
                    raw = raw[:raw.rfind(b"\n") + 1]
        except BaseException:
            lock.release()
            os.close(fd)
            raise
        return cls(path, fd, sum(1 for line in raw.split(b"\n") if line.strip()), lock)

    @classmethod
    def reopen(cls, session: LoadedSession) -> SessionWriter:
        """Append to a session to resume its campaign; the resume is recorded."""
        writer = cls.append_to(session.path, session.size_bytes or None)
        writer.write(ResumeRecord(software=f"ogacq {__version__}",
                                  after_records=len(session.records)))
        return writer

    def write(self, record: Record) -> None:
        """Append ``record``, stamped with the wall-clock time unless it has one."""
        line = record.to_json()
        self._write({"type": line.pop("type"), "wall": line.pop("wall", round(time.time(), 3)),
                     **line})

    def _write(self, record: dict[str, Any]) -> None:
        # The whole line into the OS at once: a killed process cannot lose it after
        # this; the syncer puts it on the disk.
        data = _line({**record, "seq": self._seq}).encode("utf-8")
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
        """Release the session; a last fsync that fails raises StorageError after it
        is released."""
        if self._closed:
            return
        self._closed = True
        self._syncer.finish()  # the last fsync, before the file is closed
        self._lock.release()
        os.close(self._fd)
        if self._syncer.error is not None:
            raise StorageError(self.path, self._syncer.error, "write the session")

    def __enter__(self) -> SessionWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _problem(record: Any) -> str | None:
    """What is wrong with a decoded record, or None (the header is checked on loading)."""
    if not isinstance(record, dict):
        return "not a session record"
    if record.get("type") == "session":
        return None
    try:
        record_from_json(record)
    except ValueError as exc:
        return str(exc)
    return None


def _decode(line: bytes) -> tuple[dict[str, Any] | None, str | None]:
    """(record, None), or (None, what is wrong with the line)."""
    try:
        record = json.loads(line)
    except ValueError:
        return None, "not valid JSON"
    if isinstance(record, dict) and "crc" in record:
        crc = record.pop("crc")
        body = json.dumps(record, separators=(",", ":")).encode("utf-8")
        if f"{zlib.crc32(body):08x}" != crc:
            return None, "fails its checksum: changed after it was written"
    problem = _problem(record)
    return (None, problem) if problem else (record, None)


def _parse(line: bytes) -> dict[str, Any] | None:
    return _decode(line)[0]


@dataclass(frozen=True)
class Scan:
    """Every line of a session file judged: the valid records (with their line), the
    lines that are not, and what was dropped with a warning."""

    records: list[tuple[int, dict[str, Any]]]
    problems: list[tuple[int, str]]
    warnings: list[str]
    size_bytes: int


def scan_session(path: str | Path) -> Scan:
    path = Path(path)
    try:
        raw = strip_bom(path.read_bytes())  # a session saved from an editor
    except OSError as exc:
        raise InputError(path, f"cannot read session: {exc.strerror or exc}") from None
    lines = raw.split(b"\n")
    last = max((k for k, line in enumerate(lines, 1) if line.strip()), default=0)
    records: list[tuple[int, dict[str, Any]]] = []
    problems: list[tuple[int, str]] = []
    warnings: list[str] = []
    seen: dict[int, tuple[int, dict[str, Any]]] = {}
    expected: int | None = 0  # None after a record without a number (edited by hand)
    for number, line in enumerate(lines, 1):
        if not line.strip():
            continue
        record, problem = _decode(line)
        if problem is not None:
            if number == last and not raw.endswith(b"\n"):
                # Cut by a crash mid-write (a line goes out whole, its newline last):
                # drop it, keep the rest.
                warnings.append(f"{path}:{number}: dropped a torn last record "
                                f"({len(line)} bytes: {line[:60].decode(errors='replace')!r})")
            else:
                problems.append((number, problem))
            continue
        assert record is not None
        seq = record.pop("seq", None)
        if not isinstance(seq, int):
            expected = None
        else:
            if seq in seen:
                first, earlier = seen[seq]
                if earlier == record:
                    warnings.append(f"{path}:{number}: dropped a copy of line {first}")
                else:
                    problems.append((number, f"sequence number {seq} repeats line {first} "
                                             "with other content"))
                continue
            if expected is not None and seq != expected:
                problems.append((number, f"out of sequence: record {seq} where {expected} "
                                         "was due (records lost or moved)"))
            seen[seq] = (number, record)
            expected = seq + 1
        records.append((number, record))
    return Scan(records, problems, warnings, len(raw))


def load_session(path: str | Path) -> LoadedSession:
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
    records = [r for _, r in scan.records]
    if records[0].get("format") != FORMAT:
        raise InputError(path, f"session format {records[0].get('format')!r} is not "
                         f"{FORMAT!r}", 1)
    return LoadedSession(path, records[0], [record_from_json(r) for r in records[1:]],
                         scan.warnings, scan.size_bytes)


def _not_a_session(path: Path, scan: Scan) -> InputError:
    """Why a file is not a session, said before anything about its later lines: a
    readings CSV given for a session is not a "corrupt record"."""
    if (1, "not valid JSON") in scan.problems or not scan.size_bytes:
        why = "line 1 is not a JSON record"
    else:
        why = "no session header on line 1"
    return InputError(path, f"not an ogacq session ({why}); give the session.jsonl a "
                      "campaign wrote", 1)


def salvage_session(path: str | Path, out: str | Path) -> tuple[int, list[tuple[int, str]]]:
    """Write every valid record of ``path`` to the new session ``out``, renumbered and
    checksummed; returns (records kept, the lines left out and why)."""
    scan = scan_session(path)
    kept = [r for _, r in scan.records]
    if not kept or kept[0].get("type") != "session":
        raise InputError(path, "no valid session header on line 1: nothing to salvage", 1)
    out = Path(out)
    try:
        fd = os.open(out, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_APPEND, 0o644)
    except FileExistsError:
        raise InputError(out, "exists; not overwriting it") from None
    with os.fdopen(fd, "w", encoding="utf-8") as fh:
        for seq, record in enumerate(kept):
            fh.write(_line({**record, "seq": seq}))
        fh.flush()
        os.fsync(fh.fileno())
    return len(kept), scan.problems
