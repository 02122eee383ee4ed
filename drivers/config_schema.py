"""Declared schemas for the project's TOML files: one declaration per file kind both
loads it (typed values; every error names the file, the key and, when the text is at
hand, its line) and writes it.

This is the lowest layer's file mechanics: the register-map profiles of ``drivers``
and ogacq's machine, campaign, effects and offset-table files all use it, so it
imports nothing of the project. What is wrong is reported through the caller's
error factory (``ProfileError`` for profiles, ``InputError`` for ogacq's files), so
each layer keeps its own exception.

A schema is a :class:`Table` of :class:`Field`; a field's kind is a :class:`Value`
(a scalar, with its type, range and choices), :class:`ListOf`, a nested
:class:`Table`, :class:`TableArray` (``[[name]]``), :class:`MapOf` (keys chosen by the
file's author) or :class:`Variants` (tables told apart by a tag such as ``op``).
Numbers are always finite (a nan or inf in a setting only fails later, after the
machine moved) and integers fit in 64 bits, as TOML v1.0.0 ("Integer") requires
of a parser: a 40-digit integer is a mistake in the file, not an OverflowError
when it meets a float. A field's physical bounds are its ``minimum`` and
``maximum``.
"""

from __future__ import annotations

import dataclasses
import datetime
import math
import re
import tomllib
from collections.abc import Callable, Collection, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

KeyPath = tuple[str | int, ...]

# TOML v1.0.0, "Integer": 64-bit signed integers are accepted losslessly, and an
# integer that cannot be represented losslessly is an error.
INT64 = (-(2**63), 2**63 - 1)


@dataclass(frozen=True)
class Issue:
    """One thing wrong with a file."""

    file: str
    key: str  # dotted path: "protocol.settle_s", "transport.functions[2]"; "" for the file
    problem: str  # without the key: "must be at least 0, got -1"
    message: str  # naming the key: "protocol.settle_s must be at least 0, got -1"
    line: int | None


ErrorFactory = Callable[[Issue], Exception]


# --------------------------------------------------------------------------- kinds


@dataclass(frozen=True)
class Value:
    """A scalar: one of ``types`` (int is accepted where float is, bool never is
    unless named), then range and choices."""

    types: tuple[type, ...]
    # a tuple, or a live view of a registry (``BACKENDS.keys()``) read each time a file
    # is checked: a name registered after the schema was declared is accepted
    choices: Collection[Any] = field(default=(), hash=False)
    minimum: float | None = None
    maximum: float | None = None
    positive: bool = False
    # said with the range in a refusal, where the key's name does not say it (an
    # effect's "squareness.xy" is in mrad): "must be -20..20 mrad, got 45 mrad"
    unit: str = ""


def number(*, minimum: float | None = None, maximum: float | None = None,
           positive: bool = False, unit: str = "") -> Value:
    return Value((float,), minimum=minimum, maximum=maximum, positive=positive, unit=unit)


def whole(*, minimum: int | None = None, maximum: int | None = None,
          choices: tuple[int, ...] = ()) -> Value:
    return Value((int,), choices=choices, minimum=minimum, maximum=maximum)


def text(*choices: str) -> Value:
    return Value((str,), choices=choices)


def text_among(names: Collection[str]) -> Value:
    """Text naming one of ``names`` as they are when a file is read (a registry's
    keys view), not as they were when the schema was declared."""
    return Value((str,), choices=names)


TRUTH = Value((bool,))
# TOML's own date values (RFC 3339), which tomllib gives as ``datetime.date`` and
# ``datetime.datetime``: a calendar date (``due = 2027-03-01``) and a moment
# (``date = 2026-01-10T09:00:00``, a bare date meaning its midnight). A date written
# as text ("2027-03-01") is refused with the unquoted form to write.
DATE = Value((datetime.date,))
MOMENT = Value((datetime.datetime, datetime.date))


@dataclass(frozen=True)
class FilePath:
    """A path in the file, relative to the file's folder."""


@dataclass(frozen=True)
class ListOf:
    """A list whose items are each of ``item``."""

    item: Kind


@dataclass(frozen=True)
class MapOf:
    """A table whose keys the author chooses (among ``keys`` when given)."""

    value: Kind
    keys: tuple[str, ...] = ()
    noun: str = "key"  # what a key is, for messages ("gauge")


@dataclass(frozen=True)
class Field:
    """A key of a table, its kind, and how the built object names and holds it."""

    key: str
    kind: Kind
    required: bool = False
    attr: str = ""  # the built object's attribute, when not named like the key
    decode: Callable[[Any], Any] | None = None  # file value -> attribute
    encode: Callable[[Any], Any] | None = None  # attribute -> file value

    @property
    def name(self) -> str:
        return self.attr or self.key


@dataclass(frozen=True)
class Table:
    """A table of declared keys, built into an object (``build``) or a dict."""

    fields: tuple[Field, ...]
    build: Callable[..., Any] | None = None  # called with the given fields; None: a dict
    noun: str = "key"  # what a key of this table is, for messages ("axis")

    def field(self, key: str) -> Field:
        return next(f for f in self.fields if f.key == key)


@dataclass(frozen=True)
class TableArray:
    """An array of tables (``[[name]]``), each of ``table``."""

    table: Table


@dataclass(frozen=True)
class Variants:
    """Tables told apart by the value of ``tag`` (each variant declares the tag too)."""

    tag: str
    tables: Mapping[str, Table]


Kind = Value | FilePath | ListOf | MapOf | Table | TableArray | Variants

_KIND_NAMES = {bool: "true or false", int: "a whole number", float: "a number", str: "text",
               datetime.date: "a date (YYYY-MM-DD, not quoted)",
               datetime.datetime: "a date and time (YYYY-MM-DDTHH:MM:SS, not quoted)"}


# --------------------------------------------------------------------------- the source


@dataclass
class Source:
    """A file's name and text, to name the key and the line in every error."""

    path: str
    error: ErrorFactory
    text: str = ""
    what: str = ""  # the file's role in messages ("the campaign file")
    _lines: list[str] = field(default_factory=list, repr=False)

    def __post_init__(self) -> None:
        self._lines = self.text.splitlines()

    @property
    def folder(self) -> Path:
        return Path(self.path).parent

    def line(self, path: KeyPath) -> int | None:
        """The line of ``path`` in the text: the table header or the ``key =`` line,
        or the innermost enclosing one found (a key inside an inline table)."""
        found: int | None = None
        start = 0
        tables: list[str] = []
        parent_found = True  # a key is looked for only under a table that was found
        for part in path:
            if isinstance(part, int):
                headers = self._headers(".".join(tables), array=True)
                if part < len(headers):
                    found = start = headers[part]
                continue
            tables.append(part)
            headers = self._headers(".".join(tables), array=False)
            if headers:
                found = start = headers[0]
                parent_found = True
                continue
            if self._headers(".".join(tables), array=True):
                continue  # [[part]]: the index that follows picks the entry
            at = self._key_line(part, start) if parent_found else None
            parent_found = at is not None  # [a.b] may stand without [a]: look on
            if at is not None:
                found = start = at
        return found

    def _headers(self, dotted: str, *, array: bool) -> list[int]:
        pattern = (rf"\s*\[\[\s*{re.escape(dotted)}\s*\]\]" if array
                   else rf"\s*\[\s*{re.escape(dotted)}\s*\](?!\])")
        return [n for n, line in enumerate(self._lines, 1) if re.match(pattern, line)]

    def _key_line(self, key: str, after: int) -> int | None:
        pattern = re.compile(rf"\s*(\"{re.escape(key)}\"|{re.escape(key)})\s*=")
        for number, line in enumerate(self._lines[after:], after + 1):
            if pattern.match(line):
                return number
        return None

    def fail(self, path: KeyPath, problem: str, message: str = "") -> Exception:
        """The caller's error for ``problem`` at ``path`` (``message``: the whole
        sentence, when it is not the key followed by the problem)."""
        key = dotted(path)
        message = message or (f"{key} {problem}" if key else problem)
        return self.error(Issue(self.path, key, problem, message, self.line(path)))

    def table_label(self, path: KeyPath) -> str:
        if not path:
            return self.what or "the file"
        if isinstance(path[-1], int):
            return f"[[{dotted(path[:-1])}]] entry"
        return f"[{dotted(path)}]"


def dotted(path: KeyPath) -> str:
    out = ""
    for part in path:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else part)
    return out


def read_document(path: str | Path, what: str, error: ErrorFactory,
                  ) -> tuple[dict[str, Any], Source]:
    """The parsed file and its :class:`Source`. FileNotFoundError passes through, for
    callers to whom a missing file means something (no offsets yet)."""
    source = Source(str(path), error, what=what)
    try:
        content = Path(path).read_text(encoding="utf-8-sig")  # a BOM is harmless
    except FileNotFoundError:
        raise
    except OSError as exc:
        raise source.fail((), f"cannot read {what}: {exc.strerror or exc}") from None
    except UnicodeDecodeError:
        raise source.fail((), f"{what} is not a text file") from None
    source = Source(str(path), error, content, what)
    return parse_document(source), source


def parse_document(source: Source) -> dict[str, Any]:
    try:
        return tomllib.loads(source.text)
    except ValueError as exc:  # TOMLDecodeError; or an integer of over 4300 digits
        match = re.search(r"line (\d+)", str(exc))
        line = int(match.group(1)) if match else None
        problem = (f"not valid TOML: {str(exc).split(' (at')[0]}"
                   if isinstance(exc, tomllib.TOMLDecodeError)
                   else "not valid TOML: a number of thousands of digits")
        if line is None and "(at end of document)" in str(exc):  # tomllib names no line
            line = max(1, len(source.text.splitlines()))
            problem += " (the file ends there: cut short?)"
        raise source.error(Issue(source.path, "", problem, problem, line)) from None


# --------------------------------------------------------------------------- loading


def load(schema: Table, data: Mapping[str, Any], source: Source) -> Any:
    """The file's content checked against ``schema`` and built."""
    return _load(schema, data, (), source)


def _load(kind: Kind, raw: Any, path: KeyPath, src: Source) -> Any:
    if isinstance(kind, Value):
        return _scalar(kind, raw, path, src)
    if isinstance(kind, FilePath):
        return src.folder / _scalar(text(), raw, path, src)
    if isinstance(kind, ListOf):
        if not isinstance(raw, list):
            raise src.fail(path, f"must be a list, got {raw!r}")
        return tuple(_load(kind.item, item, (*path, i), src) for i, item in enumerate(raw))
    if isinstance(kind, TableArray):
        if not isinstance(raw, list):
            raise src.fail(path, f"must be tables [[{dotted(path)}]], got {raw!r}")
        return [_load(kind.table, item, (*path, i), src) for i, item in enumerate(raw)]
    if isinstance(kind, MapOf):
        return _map(kind, raw, path, src)
    if isinstance(kind, Variants):
        tag = raw.get(kind.tag) if isinstance(raw, Mapping) else None
        if not isinstance(tag, str) or tag not in kind.tables:
            raise src.fail((*path, kind.tag), _one_of(kind.tables, tag))
        return _table(kind.tables[tag], raw, path, src)
    return _table(kind, raw, path, src)


def _table(table: Table, raw: Any, path: KeyPath, src: Source) -> Any:
    label = src.table_label(path)
    if not isinstance(raw, Mapping):
        raise src.fail(path, f"must be a table, got {raw!r}")
    known = [f.key for f in table.fields]
    for key in raw:
        if key not in known:
            import difflib  # only for a file with a mistake: every command reads a machine file

            close = difflib.get_close_matches(key, known, n=1, cutoff=0.75)
            hint = f"; did you mean {close[0]}?" if close else ""
            problem = f"unknown {table.noun} {key!r}{hint} (allowed: {', '.join(known)})"
            raise src.error(Issue(src.path, dotted(path), problem,
                                  f"unknown {table.noun} {key!r} in {label}{hint} "
                                  f"(allowed: {', '.join(known)})", src.line((*path, key))))
    given: dict[str, Any] = {}
    for f in table.fields:
        if f.key not in raw:
            if f.required:
                raise src.fail(path, f"missing {table.noun} {f.key!r}", f"{label} needs {f.key!r}")
            continue
        value = _load(f.kind, raw[f.key], (*path, f.key), src)
        given[f.name] = f.decode(value) if f.decode else value
    return table.build(**given) if table.build else given


def _map(kind: MapOf, raw: Any, path: KeyPath, src: Source) -> dict[str, Any]:
    if not isinstance(raw, Mapping):
        raise src.fail(path, f"must be a table, got {raw!r}")
    out = {}
    for key, item in raw.items():
        if kind.keys and key not in kind.keys:
            raise src.fail((*path, key), f"{kind.noun} {key!r} is not one of "
                           f"{', '.join(kind.keys)}",
                           f"{src.table_label(path)}: {kind.noun} {key!r} is not one of "
                           f"{', '.join(kind.keys)}")
        out[key] = _load(kind.value, item, (*path, key), src)
    return out


def _scalar(kind: Value, given: Any, path: KeyPath, src: Source) -> Any:
    if not _is_instance(given, kind.types):
        names = " or ".join(_KIND_NAMES[t] for t in kind.types)
        raise src.fail(path, f"must be {names}, got {_shown(given)}")
    if isinstance(given, datetime.date):
        return given
    _check_representable(given, path, src)
    if kind.choices and given not in kind.choices:
        raise src.fail(path, _one_of(kind.choices, given))
    if isinstance(given, bool) or not isinstance(given, int | float):
        return given
    _check_range(kind, given, path, src)
    if isinstance(given, int) and float in kind.types and int not in kind.types:
        return float(given)  # a whole number where a number is asked: the same value
    return given


def _check_representable(given: Any, path: KeyPath, src: Source) -> None:
    """A number the project can hold: finite, an integer within TOML's 64 bits."""
    if isinstance(given, float) and not math.isfinite(given):
        raise src.fail(path, f"must be a finite number, got {given!r}")
    if isinstance(given, int) and not isinstance(given, bool) and \
            not INT64[0] <= given <= INT64[1]:
        raise src.fail(path, f"must be a whole number of at most 19 digits (a 64-bit TOML "
                             f"integer), got one of {len(str(abs(given)))} digits")


def _check_range(kind: Value, given: float, path: KeyPath, src: Source) -> None:
    """The number within the key's bounds, said with its unit."""
    low, high = kind.minimum, kind.maximum
    unit = f" {kind.unit}" if kind.unit else ""
    if kind.positive and not given > 0:
        raise src.fail(path, f"must be positive, got {given!r}{unit}")
    if low is not None and high is not None and not low <= given <= high:
        raise src.fail(path, f"must be {low:g}..{high:g}{unit}, got {given!r}{unit}")
    if low is not None and given < low:
        raise src.fail(path, f"must be at least {low:g}{unit}, got {given!r}{unit}")
    if high is not None and given > high:
        raise src.fail(path, f"must be at most {high:g}{unit}, got {given!r}{unit}")


def _shown(value: Any) -> str:
    """A file value as its author wrote it (a date as TOML writes it)."""
    return value.isoformat() if isinstance(value, datetime.date) else repr(value)


def _is_instance(value: Any, types: tuple[type, ...]) -> bool:
    if isinstance(value, datetime.datetime):  # a datetime is a date to Python, not to us
        return datetime.datetime in types
    if isinstance(value, datetime.date):
        return datetime.date in types
    if isinstance(value, datetime.time):
        return False
    if isinstance(value, bool):  # bool is an int to Python; `address = true` is a mistake
        return bool in types
    if isinstance(value, int):
        return int in types or float in types
    return isinstance(value, types)


def _one_of(choices: Any, got: Any) -> str:
    return f"must be one of {', '.join(map(str, choices))}, got {got!r}"


# --------------------------------------------------------------------------- writing


def dump(schema: Table, value: Any, *, folder: Path | None = None, header: str = "",
         notes: Mapping[str, str] | None = None) -> str:
    """The TOML text of ``value`` (a built object or a mapping) under ``schema``:
    ``header`` comment lines first, ``notes`` (by dotted table key) as comments above
    their table. Paths are written relative to ``folder`` when inside it; values
    equal to the built class's defaults are left out, as absent keys load them."""
    out = [f"# {line}" if line else "#" for line in header.splitlines()]
    _emit(schema, value, (), out, folder, notes or {})
    return "\n".join(out).strip("\n") + "\n"


def _emit(table: Table, value: Any, path: KeyPath, out: list[str], folder: Path | None,
          notes: Mapping[str, str]) -> None:
    sections: list[tuple[Field, Any]] = []
    for f, item in _present(table, value):
        if _is_section(f.kind):
            sections.append((f, item))
        else:
            out.append(f"{_key(f.key)} = {_literal(f.kind, item, (*path, f.key), folder)}")
    for f, item in sections:
        if not item:
            continue  # no [[entries]], an empty map: nothing to write
        where = (*path, f.key)
        name = ".".join(_key(str(p)) for p in where)
        out.append("")
        if dotted(where) in notes:
            out += [f"# {line}" for line in notes[dotted(where)].splitlines()]
        kind = f.kind
        if isinstance(kind, TableArray):
            for k, entry in enumerate(item):
                if k:
                    out.append("")
                out.append(f"[[{name}]]")
                _emit(kind.table, entry, where, out, folder, notes)
        elif isinstance(kind, MapOf):
            out.append(f"[{name}]")
            out += [f"{_key(k)} = {_literal(kind.value, v, (*where, k), folder)}"
                    for k, v in item.items()]
        else:
            out.append(f"[{name}]")
            _emit(_chosen(kind, item), item, where, out, folder, notes)


def _present(table: Table, value: Any) -> list[tuple[Field, Any]]:
    """The fields to write, with their file values."""
    defaults = _defaults(value)
    out = []
    for f in table.fields:
        item = value.get(f.name) if isinstance(value, Mapping) else getattr(value, f.name)
        if item is None or (f.name in defaults and item == defaults[f.name]):
            continue
        out.append((f, f.encode(item) if f.encode else item))
    return out


def _defaults(value: Any) -> dict[str, Any]:
    if not dataclasses.is_dataclass(value):
        return {}
    out = {}
    for f in dataclasses.fields(value):
        if f.default is not dataclasses.MISSING:
            out[f.name] = f.default
        elif f.default_factory is not dataclasses.MISSING:
            out[f.name] = f.default_factory()
    return out


def _is_section(kind: Kind) -> bool:
    return isinstance(kind, Table | TableArray | Variants) or (
        isinstance(kind, MapOf) and isinstance(kind.value, Table | Variants))


def _chosen(kind: Kind, value: Any) -> Table:
    if isinstance(kind, Variants):
        tag = value[kind.tag] if isinstance(value, Mapping) else getattr(value, kind.tag)
        return kind.tables[tag]
    assert isinstance(kind, Table)
    return kind


def _literal(kind: Kind, value: Any, path: KeyPath, folder: Path | None) -> str:
    if isinstance(kind, FilePath):
        return _basic_string(_relative(Path(value), folder))
    if isinstance(kind, ListOf):
        return "[" + ", ".join(_literal(kind.item, v, (*path, i), folder)
                               for i, v in enumerate(value)) + "]"
    if isinstance(kind, MapOf | Table | Variants):
        fields = (_present(_chosen(kind, value), value) if not isinstance(kind, MapOf)
                  else [(Field(k, kind.value), v) for k, v in value.items()])
        return "{ " + ", ".join(f"{_key(f.key)} = {_literal(f.kind, v, (*path, f.key), folder)}"
                                for f, v in fields) + " }"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, datetime.date):
        return value.isoformat()  # a TOML date or local date-time, unquoted
    if isinstance(value, float):
        if not math.isfinite(value):
            raise ValueError(f"{dotted(path)} = {value}: not a finite number")
        return repr(value)  # repr round-trips a float exactly and is valid TOML
    return str(value) if isinstance(value, int) else _basic_string(str(value))


def _key(key: str) -> str:
    return key if re.fullmatch(r"[A-Za-z0-9_-]+", key) else _basic_string(key)


def _basic_string(text: str) -> str:
    """``text`` as a TOML basic string, which a JSON string is (TOML v1.0.0, "String":
    the same escapes). json is imported here, for writing: reading a file needs none
    of it."""
    import json

    return json.dumps(text)


def _relative(path: Path, folder: Path | None) -> str:
    if folder is None:
        return str(path)
    try:
        return str(path.resolve().relative_to(folder.resolve()))
    except ValueError:
        return str(path.resolve())
