"""Campaign sessions: one append-only file of JSON records, one per line.

Every reading, move, prompt answer and event is written to the operating
system as it happens, so a crash, a Ctrl-C or a killed process loses nothing
that was measured; a background thread then forces each record to the disk
(fsync) within milliseconds, against a power cut, without holding the campaign
up for the disk's latency. The first record describes the session (machine, station,
plan, software version); the rest are appended in the order they happened. A
record cut by a crash mid-write (a torn last line) is dropped on loading with a
warning naming it; everything before it stands.
"""

from __future__ import annotations

import json
import os
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ogacq import __version__
from ogacq.io.errors import InputError

FORMAT = "ogacq-session/1"


@dataclass
class LoadedSession:
    path: Path
    header: dict[str, Any]
    records: list[dict[str, Any]]
    warnings: list[str] = field(default_factory=list)

    def of_type(self, kind: str) -> list[dict[str, Any]]:
        return [r for r in self.records if r.get("type") == kind]

    @property
    def readings(self) -> list[dict[str, Any]]:
        return self.of_type("reading")

    def recorded(self) -> set[tuple[str, str]]:
        """(step id, gauge) of every reading on file."""
        return {(r["step"], r["gauge"]) for r in self.readings}

    @property
    def finished(self) -> bool:
        return any(r.get("type") == "end" and r.get("status") == "complete"
                   for r in self.records)


class _Syncer(threading.Thread):
    """Forces written records to the disk soon after they are written."""

    def __init__(self, fd: int) -> None:
        super().__init__(name="session-fsync", daemon=True)
        self._fd = fd
        self._pending = threading.Event()
        self._closing = False

    def poke(self) -> None:
        self._pending.set()

    def run(self) -> None:
        while True:
            self._pending.wait()
            self._pending.clear()
            os.fsync(self._fd)
            if self._closing:
                return

    def finish(self) -> None:
        self._closing = True
        self._pending.set()
        self.join()


class SessionWriter:
    """Appends records durably. Opened on a new file (``create``) or to resume."""

    def __init__(self, path: Path, handle) -> None:
        self.path = path
        self._fh = handle
        self._syncer = _Syncer(handle.fileno())
        self._syncer.start()

    @classmethod
    def create(cls, path: str | Path, header: dict[str, Any]) -> SessionWriter:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        try:
            fh = path.open("x", encoding="utf-8")
        except FileExistsError:
            raise InputError(path, "a session already exists here; resume it with "
                             f"`ogacq resume {path}` or choose another name") from None
        writer = cls(path, fh)
        writer._write({"type": "session", "format": FORMAT, "software": f"ogacq {__version__}",
                       "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"), **header})
        return writer

    @classmethod
    def append_to(cls, path: str | Path) -> SessionWriter:
        """A writer at the end of an existing session, after cutting off a torn last
        record (appending after it would corrupt the file)."""
        path = Path(path)
        raw = path.read_bytes()
        if raw and not raw.endswith(b"\n"):
            with path.open("r+b") as fh:
                fh.truncate(raw.rfind(b"\n") + 1)
        return cls(path, path.open("a", encoding="utf-8"))

    @classmethod
    def reopen(cls, session: LoadedSession) -> SessionWriter:
        """Append to a session to resume its campaign; the resume is recorded."""
        writer = cls.append_to(session.path)
        writer.append("resume", software=f"ogacq {__version__}",
                      after_records=len(session.records))
        return writer

    def append(self, kind: str, **fields: Any) -> None:
        self._write({"type": kind, "wall": round(time.time(), 3), **fields})

    def _write(self, record: dict[str, Any]) -> None:
        # One write of the whole line, then into the OS: a killed process cannot
        # lose it after this; the syncer puts it on the disk.
        self._fh.write(json.dumps(record, separators=(",", ":")) + "\n")
        self._fh.flush()
        self._syncer.poke()

    def close(self) -> None:
        if not self._fh.closed:
            self._fh.flush()
            self._syncer.finish()  # the last fsync, before the file is closed
            self._fh.close()

    def __enter__(self) -> SessionWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def load_session(path: str | Path) -> LoadedSession:
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise InputError(path, f"cannot read session: {exc.strerror or exc}") from None
    lines = raw.split(b"\n")
    records: list[dict[str, Any]] = []
    warnings: list[str] = []
    for number, line in enumerate(lines, 1):
        if not line.strip():
            continue
        try:
            record = json.loads(line)
            if not isinstance(record, dict) or "type" not in record:
                raise ValueError("not a record")
        except ValueError:
            last = number == len(lines) or all(not rest.strip() for rest in lines[number:])
            if last:  # a crash mid-write: drop it, keep the rest
                warnings.append(f"{path}:{number}: dropped a torn last record "
                                f"({len(line)} bytes: {line[:60].decode(errors='replace')!r})")
                continue
            raise InputError(path, "corrupt record in the middle of the session "
                             "(not valid JSON)", number) from None
        records.append(record)
    if not records or records[0].get("type") != "session":
        raise InputError(path, "not an ogacq session (no session header on line 1)", 1)
    if records[0].get("format") != FORMAT:
        raise InputError(path, f"session format {records[0].get('format')!r} is not "
                         f"{FORMAT!r}", 1)
    return LoadedSession(path, records[0], records[1:], warnings)
