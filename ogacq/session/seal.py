"""The seal on every line of a session, and the check of every seal on reading.

A record written by this version ends with three keys the store adds:

* ``seq``: its place in the file, the header 0;
* ``prev`` (not on the header): the CRC-32 of the line before it, as written;
* ``crc``: the CRC-32 of its own line without this key (compact JSON).

and the header says so: ``"integrity": "crc32-chain/1"``. A record changed after
it was written fails its ``crc``; one whose ``crc`` (or ``seq``, or ``prev``) was
deleted is missing what every record of a sealed session has; a record removed,
inserted or moved breaks the ``seq`` and the ``prev`` of the one after it. So an
edit is found whichever keys it touched, unless whoever made it recomputed every
checksum after it: CRC-32 finds a disk's and an editor's changes, it is not a
signature.

The seals prove every record up to the last one, not that the last one is the last
written: a tail cut off at a line end leaves a file whose every record is as
written. So each writer ends its turn with a ``closed`` record (a campaign, its
resume, a write-back's audit), and the header announces it (``"closing":
"closed"``): a session that announces it and does not end with one either has a
writer now (its lock), or its last writer was killed before it closed, or the file
was cut after its last record (:class:`Closure`: the file alone cannot tell a kill
from a cut, so neither is vouched for; the history's own count of the session's
records finds a cut that ends at an earlier writer's ``closed`` record). The
``closed`` records are the store's, as ``seq`` and ``crc`` are: they are checked in
the chain and not loaded as records.

A session whose header has no ``integrity`` (its seals stripped, or written before
them) is ``unchecked`` and says so (:class:`Integrity`); a record with a chain
checksum under such a header means the header was edited. (The per-record
checksums without a chain of 0.1.0's development, 23-27 November 2026, are read as
unchecked: nothing released wrote them.)

Each problem is one of three kinds: a line that cannot be read (not JSON, not a
record of its type: ``problems``), a readable record that is not as it was
written (``changed``: ``ogacq session salvage`` leaves it out), or a record as
written that is not where it was written (out of sequence, out of the chain).
The last two together are ``edited``: an analysis refuses them unless the user
accepts the session as it stands.
"""

from __future__ import annotations

import json
import threading
import zlib
from collections import OrderedDict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ogacq.io.errors import InputError
from ogacq.io.text import strip_bom
from ogacq.session.records import Record, record_from_json

# The header's ``integrity``: the seal this version writes, and those it checks.
SEAL = "crc32-chain/1"
SEALS = (SEAL,)

SEALED = "sealed"  # every record with seq, prev and crc, chained
UNCHECKED = "unchecked"  # the header without a seal

_STORE_KEYS = ("seq", "prev", "crc")

# The record that ends each writer's turn, and the header key that announces it.
CLOSED = "closed"
CLOSING_KEY = "closing"


def line_crc(line: bytes) -> str:
    """The chain checksum of a line as written (without its line end)."""
    crc = zlib.crc32(line.rstrip(b"\r\n"))
    return f"{crc:08x}"


def seal_line(record: dict[str, Any], seq: int, prev: str | None) -> bytes:
    """``record`` as one line with its ``seq``, its ``prev`` (None: the header, or a
    record appended to a session written before the chain) and its ``crc`` last."""
    fields = {k: v for k, v in record.items() if k not in _STORE_KEYS}
    fields["seq"] = seq
    if prev is not None:
        fields["prev"] = prev
    body = json.dumps(fields, separators=(",", ":"))
    crc = zlib.crc32(body.encode("utf-8"))
    return f'{body[:-1]},"crc":"{crc:08x}"}}\n'.encode()


@dataclass(frozen=True)
class Integrity:
    """How far a loaded session can vouch for itself: its header's format, and the
    records found edited that the user accepted (``--accept-edited``)."""

    mode: str = SEALED
    edited: tuple[tuple[int, str], ...] = ()

    def notes(self) -> list[str]:
        """What every output of an analysis says about it (nothing for a sealed,
        untouched session)."""
        out = []
        if self.edited:
            line, problem = self.edited[0]
            more = f", and {len(self.edited) - 1} more" if len(self.edited) > 1 else ""
            out.append(f"edited: line {line} {problem}{more}; taken as it stands")
        if self.mode == UNCHECKED:
            out.append("unchecked: a session written before ogacq checksummed its records "
                       "(an edit to it cannot be found)")
        return out

    def to_json(self) -> dict[str, Any]:
        return {"integrity": self.mode,
                "edited": [{"line": line, "problem": problem} for line, problem in self.edited]}


@dataclass(frozen=True)
class Closure:
    """Whether the session's file ends where its last writer ended it: ``announced``
    (its header says each writer closes), ``closed`` (it ends with a ``closed``
    record), the line of its last record, and the line of a torn record a crash
    left after it (dropped on loading)."""

    announced: bool
    closed: bool
    last_line: int
    torn_line: int | None = None

    def problem(self) -> str | None:
        """Why the file's end cannot be vouched for, or None."""
        if self.torn_line is not None:
            return (f"line {self.torn_line} is a torn record: its writer was stopped "
                    "mid-write (killed, or a power loss)")
        if self.announced and not self.closed:
            return (f"not closed after line {self.last_line}: its last writer was killed "
                    "before it closed the session, or the records after that line were "
                    "removed")
        return None


@dataclass(frozen=True)
class Scan:
    """Every line of a session file judged (see the module's docstring)."""

    mode: str
    records: list[tuple[int, dict[str, Any]]]  # every readable record, store keys taken off
    problems: list[tuple[int, str]]  # lines that cannot be read
    edited: list[tuple[int, str]]  # readable, but not as or where written
    changed: frozenset[int]  # lines of ``edited`` whose own content is not as written
    warnings: list[str]
    size_bytes: int
    closure: Closure = Closure(announced=False, closed=False, last_line=0)
    # the typed record of each line of ``records`` but a session header, by line
    typed: dict[int, Record] = field(default_factory=dict)

    @property
    def untouched(self) -> list[tuple[int, dict[str, Any]]]:
        """The records as they were written (what salvage keeps)."""
        return [(n, r) for n, r in self.records if n not in self.changed]


@dataclass
class _Line:
    """One decoded line: its JSON object (the store's keys taken off), and what its
    own seal says."""

    content: dict[str, Any]
    crc: str  # "ok", "missing", "wrong"
    seq: Any
    prev: Any
    record: Record | None  # the content typed (None: a session header)


Decoded = tuple[_Line | None, str | None]


def _decode(line: bytes) -> Decoded:
    """(the line decoded, None), or (None, why it cannot be read)."""
    try:
        content = json.loads(line)
    except UnicodeDecodeError as exc:  # a byte an editor wrote in another encoding, or a disk's
        return None, (f"not valid JSON: not UTF-8 text (byte 0x{line[exc.start]:02x} at "
                      f"column {len(line[:exc.start].decode(errors='replace')) + 1})")
    except ValueError:
        return None, "not valid JSON"
    if not isinstance(content, dict):
        return None, "not a session record"
    crc = content.pop("crc", None)
    if crc is None:
        state = "missing"
    else:
        body = json.dumps(content, separators=(",", ":")).encode("utf-8")
        state = "ok" if crc == f"{zlib.crc32(body):08x}" else "wrong"
    seq, prev = content.pop("seq", None), content.pop("prev", None)
    record = None
    if content.get("type") != "session":
        try:
            record = record_from_json(content)
        except ValueError as exc:
            return None, str(exc)
    return _Line(content, state, seq, prev, record), None


def parses(line: bytes) -> bool:
    """Whether a line is a whole record (a newline-less last line may be one)."""
    decoded, _ = _decode(line)
    return decoded is not None and decoded.crc != "wrong"


def _mode(first: _Line | None) -> tuple[str, str | None]:
    seal = None if first is None or first.content.get("type") != "session" \
        else first.content.get("integrity")
    return (UNCHECKED, None) if seal is None else (SEALED, seal)


# The lines of the sessions read last, decoded, by file and line. A campaign, and a
# calibration's four, read their session again after each stage appends to it (its fit,
# its record, the history's): decoding and typing each line is most of a reading, and
# the same bytes decode the same, so only the lines not read before are decoded again.
# The few files read last are kept (a long process reads many sessions).
_DECODED: OrderedDict[Path, dict[bytes, Decoded]] = OrderedDict()
_DECODED_LOCK = threading.Lock()  # a session read in two threads at once: each decodes
DECODED_FILES = 4


def scan_session(path: str | Path) -> Scan:
    path = Path(path)
    try:
        raw = strip_bom(path.read_bytes())  # a session saved from an editor
    except OSError as exc:
        raise InputError(path, f"cannot read session: {exc.strerror or exc}") from None
    key = path.resolve()
    with _DECODED_LOCK:
        known = _DECODED.pop(key, {})
    scanner = _Scanner(path, raw, known)
    scan = scanner.scan()
    with _DECODED_LOCK:
        _DECODED[key] = scanner.decoded
        while len(_DECODED) > DECODED_FILES:
            _DECODED.popitem(last=False)
    return scan


class _Scanner:
    def __init__(self, path: Path, raw: bytes, known: dict[bytes, Decoded]) -> None:
        self.path = path
        self.raw = raw
        self.lines = raw.split(b"\n")
        self.known = known  # lines decoded by an earlier reading of the file
        self.decoded: dict[bytes, Decoded] = {}  # this reading's, for the next one
        self.records: list[tuple[int, dict[str, Any]]] = []
        self.typed: dict[int, Record] = {}
        self.problems: list[tuple[int, str]] = []
        self.edited: list[tuple[int, str]] = []
        self.changed: set[int] = set()
        self.warnings: list[str] = []
        self.torn_line: int | None = None
        self.closed = False  # the last record read is a closed record
        # the chain as read so far: the first line of each sequence number, the number
        # the next record should carry (None, unchecked: after a record without one), and
        # the last line read (its number, its bytes, whether as written)
        self.seen: dict[int, tuple[int, dict[str, Any]]] = {}
        self.expected: int | None = 0
        self.previous: tuple[int, bytes, bool] | None = None

    def scan(self) -> Scan:
        last = max((k for k, line in enumerate(self.lines, 1) if line.strip()), default=0)
        first, _ = self._decode(self.lines[0]) if self.lines and self.lines[0].strip() \
            else (None, None)
        mode, seal = _mode(first)
        if seal is not None and seal not in SEALS:
            self.problems.append((1, f"sealed as {seal!r}, which this ogacq does not know "
                                     "(written by a newer one): update ogacq"))
        for number, line in enumerate(self.lines, 1):
            if not line.strip():
                continue
            decoded, problem = self._decode(line)
            if decoded is None:
                self._undecodable(number, line, number == last, problem)
            elif not self._a_copy(number, decoded):
                self._chained(number, line, decoded, mode)
        announced = first is not None and first.content.get(CLOSING_KEY) == CLOSED
        closure = Closure(announced, self.closed, self.previous[0] if self.previous else 0,
                          self.torn_line)
        return Scan(mode, self.records, self.problems, self.edited, frozenset(self.changed),
                    self.warnings, len(self.raw), closure, self.typed)

    def _decode(self, line: bytes) -> Decoded:
        if line not in self.decoded:
            known = self.known.get(line)
            self.decoded[line] = _decode(line) if known is None else known
        return self.decoded[line]

    def _undecodable(self, number: int, line: bytes, last: bool, problem: str | None) -> None:
        """A line that is no record: a torn last one is dropped (a line goes out whole,
        its newline last, so a crash mid-write cuts only the last), and the rest stands;
        anywhere else it is a problem."""
        if last and not self.raw.endswith(b"\n"):
            self.warnings.append(
                f"{self.path}:{number}: dropped a torn last record ({len(line)} "
                f"bytes: {line[:60].decode(errors='replace')!r})")
            self.torn_line = number
            return
        assert problem is not None
        self.problems.append((number, problem))
        self.previous = (number, line, False)
        self.closed = False

    def _a_copy(self, number: int, line: _Line) -> bool:
        """A record written twice (same number, same content): dropped, said, and the
        chain goes on from the original."""
        seq = line.seq
        if not isinstance(seq, int) or isinstance(seq, bool) or seq not in self.seen:
            return False
        first_line, earlier = self.seen[seq]
        if earlier != line.content:
            return False
        self.warnings.append(f"{self.path}:{number}: dropped a copy of line {first_line}")
        return True

    def _chained(self, number: int, raw: bytes, line: _Line, mode: str) -> None:
        """A record: its own seal, then its place in the chain, checked; kept unless it
        is the store's own closed record."""
        content, seq = line.content, line.seq
        own = self._own_seal(number, line, mode)
        if own:
            self.changed.add(number)
            self.edited.append((number, own))
        else:
            where = self._placement(number, line, mode, self.seen, self.expected, self.previous)
            if where:
                self.edited.append((number, where))
        if isinstance(seq, int) and not isinstance(seq, bool):
            self.seen.setdefault(seq, (number, content))
            self.expected = seq + 1
        elif mode == UNCHECKED:
            self.expected = None
        self.previous = (number, raw, not own)
        self.closed = content.get("type") == CLOSED
        if not self.closed:  # the store's own record, checked in the chain above
            self.records.append((number, content))
            if line.record is not None:
                self.typed[number] = line.record

    @staticmethod
    def _own_seal(number: int, line: _Line, mode: str) -> str | None:
        """What is wrong with the line's own seal, or None."""
        if line.crc == "wrong":
            return "fails its checksum: changed after it was written"
        if mode == UNCHECKED:
            if line.prev is not None and number > 1:
                return ("carries a chain checksum under a header without a seal: the header "
                        "was edited")
            return None
        if line.crc == "missing":
            return "has no checksum (crc): every record of this session had one"
        if not isinstance(line.seq, int) or isinstance(line.seq, bool):
            return "has no sequence number (seq): every record of this session had one"
        if number > 1 and line.prev is None:
            return "has no chain checksum (prev): every record of this session had one"
        return None

    @staticmethod
    def _placement(number: int, line: _Line, mode: str, seen: dict[int, tuple[int, dict[str, Any]]],
                   expected: int | None, previous: tuple[int, bytes, bool] | None) -> str | None:
        """Whether a record as written is where it was written, or what says not."""
        seq = line.seq
        if isinstance(seq, int) and not isinstance(seq, bool):
            if seq in seen:
                return f"sequence number {seq} repeats line {seen[seq][0]} with other content"
            if expected is not None and seq != expected:
                return (f"out of sequence: record {seq} where {expected} was due (records "
                        "removed, inserted or moved)")
        if mode == SEALED and previous is not None and line.prev is not None:
            at, before, intact = previous
            # a line after one already found changed: that one says it
            if intact and line.prev != line_crc(before):
                return (f"does not follow line {at} as written: a record before it was "
                        "removed, inserted or changed")
        return None
