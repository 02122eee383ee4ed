"""Readings CSV and deviations CSV (INTERCHANGE.md): strict readers, one writer.

Every problem is reported with the file, the line and what is wrong; nothing is
guessed. Values are in mm: a column in another unit, or with none, is refused
rather than converted silently. A number is written as a CSV number is: ASCII
digits, a sign, a point and an exponent (what Python's ``float`` also takes --
fullwidth or Arabic-Indic digits, ``1_000`` -- is refused), finite, and within
physical bounds: a length within 100 m, a time within 30 years, a cycle within a
million.
"""

from __future__ import annotations

import csv
import io
import math
import re
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ogacq.identify.observations import Deviation
from ogacq.io.atomic import write_atomically
from ogacq.io.errors import InputError
from ogacq.io.text import check_line_ends, decode_text, read_text
from ogacq.model.gauges import Gauge
from ogacq.model.kinematics import nominal_tcp
from ogacq.model.machine import MachineSpec
from ogacq.model.measurement import ReadingsLayout
from ogacq.model.parameters import AXES

READINGS_COLUMNS = ("t_s", "cycle", "leg", "gauge_axis", "tcp_x", "tcp_y", "tcp_z",
                    "q_x", "q_y", "q_z", "reading_mm")
# Our own export adds the side each joint approached from; other tools ignore it.
APPROACH_COLUMNS = ("approach_x", "approach_y", "approach_z")
DEVIATIONS_COLUMNS = ("name", "value_mm")
_OTHER_UNITS = {"_in": "inches", "_inch": "inches", "_um": "micrometres", "_m": "metres",
                "_cm": "centimetres"}

# A decimal number as a CSV writes it (ASCII only; spaces around it are the writer's)
_NUMBER = re.compile(r"[ \t]*[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?[ \t]*", re.ASCII)
# Physical bounds (no source: beyond any machine this tool calibrates, as the machine
# file's lengths): a length in mm, a time in s, a repeat index.
MAX_LENGTH_MM = 1e5
MAX_TIME_S = 1e9
MAX_CYCLE = 1_000_000
_BOUNDS = {"t_s": MAX_TIME_S, "reading_mm": MAX_LENGTH_MM, "value_mm": MAX_LENGTH_MM,
           **{f"{c}_{a}": MAX_LENGTH_MM for c in ("tcp", "q") for a in AXES}}


@dataclass
class ReadingsTable:
    """A readings CSV's columns (docs/formats.md), one row per reading."""

    t_s: np.ndarray
    cycle: np.ndarray
    leg: np.ndarray
    gauge_axis: np.ndarray
    tcp_mm: np.ndarray
    q_mm: np.ndarray
    reading_mm: np.ndarray
    approach: np.ndarray | None
    lines: np.ndarray  # file line of each row, for messages

    def layout(self) -> ReadingsLayout:
        return ReadingsLayout.build(self.q_mm, self.leg, self.gauge_axis, self.t_s, self.cycle,
                                    self.tcp_mm, self.approach)


def sniff(path: str | Path) -> str:
    """"readings", "deviations" or "session" from the file's first line (and its second,
    to say what a file of neither format holds)."""
    path = Path(path)
    try:
        with path.open("rb") as fh:
            first_bytes = fh.readline()
            first = decode_text(first_bytes, path)
            if first.lstrip().startswith("{"):
                return "session"
            check_line_ends(path, first)
            header = {h.strip() for h in next(csv.reader([first]), [])}
            if "name" in header:
                return "deviations"
            if header & {"leg", "gauge_axis"}:
                return "readings"
            # decoded with the first, for a wrong byte's line number
            second = decode_text(first_bytes + fh.readline(), path)[len(first):]
    except OSError as exc:
        raise InputError(path, f"cannot read: {exc.strerror or exc}") from None
    raise InputError(path, _unrecognised_header(first, second), 1)


# The field separators of spreadsheets in locales whose decimal mark is a comma
_OTHER_SEPARATORS = {";": ("';'", "a spreadsheet's export in a locale writing decimal commas?"),
                     "\t": ("tabs", "a spreadsheet's text export?")}
_DECIMAL_COMMA = re.compile(r"[ \t]*\"?[+-]?[0-9]+,[0-9]+\"?[ \t]*", re.ASCII)
# A column named with its unit apart: "reading (mm)", "value [mm]", "Reading mm"
_UNIT_APART = re.compile(r"[ \t]*[(\[]?[ \t]*mm[ \t]*[)\]]?[ \t]*$")


def _format_columns(cells: set[str]) -> tuple[str, tuple[str, ...]] | None:
    """Which format a header's (normalised) names belong to, if any."""
    if "name" in cells:
        return "a deviations CSV", DEVIATIONS_COLUMNS
    if cells & {"leg", "gauge_axis"}:
        return "a readings CSV", READINGS_COLUMNS
    return None


def _normalised(name: str) -> str:
    """A column's name as the format would write it: lowercase, the unit joined by '_'."""
    name = name.strip().strip('"').lower()
    if _UNIT_APART.search(name) and not name.endswith("_mm"):
        name = _UNIT_APART.sub("", name) + "_mm"
    return re.sub(r"[ \t]+", "_", name)


def _separator_problem(first: str, second: str) -> str | None:
    """Words for a header whose fields are separated otherwise than by ',' (a
    spreadsheet's export in a locale writing decimal commas), none if it is not one."""
    for separator, (said, why) in _OTHER_SEPARATORS.items():
        cells = {_normalised(c) for c in first.split(separator)}
        found = _format_columns(cells) if len(cells) > 1 else None
        if found is None:
            continue
        commas = any(_DECIMAL_COMMA.fullmatch(c) for c in second.strip().split(separator))
        return (f"fields are separated by {said}"
                + (" and decimals written with ','" if commas else "")
                + f" ({why}): {found[0]} uses ',' between "
                "fields and '.' in numbers; export it again with those, or replace them")
    return None


def _renamed_column(header: Sequence[str], column: str) -> str | None:
    """Words for a header cell that is ``column`` written otherwise."""
    for cell in header:
        if cell != column and _normalised(cell) == column:
            return (f"column {cell!r} is the format's {column!r} named otherwise: name it "
                    f"{column!r} (lowercase, the unit joined by '_')")
    return None


def _unrecognised_header(first: str, second: str) -> str:
    """What line 1 of a file that is neither CSV format nor a session holds, and what
    the formats want."""
    line = first.rstrip("\r\n")
    expected = (f"a readings CSV ({', '.join(READINGS_COLUMNS)}) or a deviations CSV "
                "(name,value_mm)")
    if not first:
        return f"empty file: expected {expected}"
    if not line.strip():
        return f"empty first line: the file begins with its header row, {expected}"
    if line.lstrip().startswith("#"):
        return (f"line 1 is a comment ({_shown(line)}): the file begins with its header row, "
                f"{expected}, and holds no comment lines; delete it")
    problem = _separator_problem(first, second)
    if problem is not None:
        return problem
    header = [h.strip() for h in next(csv.reader([first]), [])]
    found = _format_columns({_normalised(h) for h in header})
    if found is not None:
        for column in found[1]:
            renamed = _renamed_column(header, column)
            if renamed is not None:
                return renamed
    return f"unrecognised header {_shown(line)}: expected {expected}"


def _shown(text: str, most: int = 60) -> str:
    """``text`` quoted, cut at ``most`` characters."""
    return repr(text[:most] + ("..." if len(text) > most else ""))


def _read_csv(path: Path, text: str | None) -> tuple[list[str], list[tuple[int, list[str]]]]:
    """The header and the rows that hold something, each with its line."""
    try:
        if text is None:
            text = read_text(path)
        check_line_ends(path, text)
        reader = csv.reader(io.StringIO(text, newline=""))
        header = [h.strip() for h in next(reader, [])]
        rows = [(reader.line_num, row) for row in reader if "".join(row).strip()]
    except OSError as exc:
        raise InputError(path, f"cannot read: {exc.strerror or exc}") from None
    except csv.Error as exc:
        raise InputError(path, f"not a readable CSV file: {exc}") from None
    return header, rows


def _check_units(path: Path, header: list[str], required: Sequence[str]) -> None:
    """Refuse a required mm column given in another unit."""
    for col in header:
        for suffix, unit in _OTHER_UNITS.items():
            if col.endswith(suffix) and col[: -len(suffix)] + "_mm" in required:
                raise InputError(path, f"column {col!r} is in {unit}; this format takes mm: "
                                 f"convert and name it {col[: -len(suffix)]}_mm", 1)


def _check_columns(path: Path, header: list[str], required: Sequence[str],
                   first_row: str = "") -> None:
    """Refuse a header without a required column (one without its unit said so), or
    with a column twice."""
    missing = [c for c in required if c not in header]
    if missing:
        col = missing[0]
        if col.endswith("_mm") and col[:-3] in header:
            raise InputError(path, f"column {col[:-3]!r} has no unit: values must be in mm and "
                             f"the column named {col!r}", 1)
        raise InputError(path, _renamed_column(header, col)
                         or _missing_column(header, col, first_row), 1)
    if len(set(header)) != len(header):
        dup = next(h for h in header if header.count(h) > 1)
        raise InputError(path, f"column {dup!r} appears twice in the header", 1)


def _missing_column(header: list[str], column: str, first_row: str) -> str:
    if header and header[0].lstrip().startswith("#"):
        return (f"line 1 is a comment ({_shown(','.join(header))}): the file begins with its "
                "header row and holds no comment lines; delete it")
    if len(header) == 1:  # one field: separated otherwise than by ','?
        problem = _separator_problem(header[0], first_row)
        if problem is not None:
            return problem
    return f"missing column {column!r} (header has: {', '.join(header)})"


def _rows(path: Path, required: Sequence[str], text: str | None = None,
          ) -> tuple[list[str], list[tuple[int, list[str]]]]:
    header, rows = _read_csv(path, text)
    if not header:
        raise InputError(path, "empty file: no header row", 1)
    _check_units(path, header, required)
    _check_columns(path, header, required, ",".join(rows[0][1]) if rows else "")
    if not rows:
        raise InputError(path, "no data rows after the header", 2)
    return header, rows


def _ascii_float(text: str) -> float:
    """``text`` as a number if it is written as one in ASCII, else NaN."""
    return float(text) if _NUMBER.fullmatch(text) else math.nan


def _number(path: Path, line: int, column: str, text: str) -> float:
    shown = text.strip()[:40] + ("..." if len(text.strip()) > 40 else "")
    if not _NUMBER.fullmatch(text):
        if text.strip().lower().lstrip("+-") in ("nan", "inf", "infinity"):
            raise InputError(path, f"{column}: {shown!r} is not a finite number", line)
        raise InputError(path, f"{column}: {shown!r} is not a number (ASCII digits, a sign, a "
                         "point, an exponent)", line)
    value = float(text)
    if not math.isfinite(value):
        raise InputError(path, f"{column}: {shown!r} is not a finite number", line)
    bound = _BOUNDS.get(column)
    if bound is not None and abs(value) > bound:
        raise InputError(path, f"{column}: {shown} is beyond {bound:g}, more than any machine "
                         "this tool calibrates", line)
    return value


def _misfit(row: list[str], header: list[str]) -> bool:
    """A row with fewer fields than the header, or more that hold something: an empty
    trailing field is a spreadsheet's habit, a filled one most often a decimal comma
    ("12,345") that would otherwise be read as 12 with the rest dropped."""
    return len(row) < len(header) or any(cell.strip() for cell in row[len(header):])


def _fields_problem(row: list[str], header: list[str]) -> str:
    more = " (a decimal comma? write 12.345)" if len(row) > len(header) else ""
    return f"row has {len(row)} fields, the header {len(header)}{more}"


def read_deviations(path: str | Path) -> list[tuple[str, float]]:
    path = Path(path)
    header, rows = _rows(path, DEVIATIONS_COLUMNS)
    at = {c: header.index(c) for c in DEVIATIONS_COLUMNS}
    out: list[tuple[str, float]] = []
    seen: dict[str, int] = {}
    for line, row in rows:
        if _misfit(row, header):
            raise InputError(path, _fields_problem(row, header), line)
        name = row[at["name"]].strip()
        try:
            Deviation.parse(name)
        except ValueError:
            raise InputError(path, f"{name!r} is not a deviation name: expected dX_Y+, dX_Y- "
                             "(relative to Zero) or dX_Y (Max minus Min), X != Y in x, y, z",
                             line) from None
        if name in seen:
            raise InputError(path, f"{name} appears twice (first at line {seen[name]})", line)
        _check_one_form(path, line, name, seen)
        seen[name] = line
        out.append((name, _number(path, line, "value_mm", row[at["value_mm"]])))
    return out


def _check_one_form(path: Path, line: int, name: str, seen: dict[str, int]) -> None:
    """Refuse a gauge's Max minus Min (``dx_y``) beside its deviations relative to Zero
    (``dx_y+``, ``dx_y-``): the one is the difference of the others, and would count
    the same readings twice."""
    gauge = name.rstrip("+-")
    other = [n for n in ((gauge + "+", gauge + "-") if name == gauge else (gauge,)) if n in seen]
    if other:
        raise InputError(path, f"{name} and {other[0]} (line {seen[other[0]]}) give the same "
                         f"gauge's deviations twice: {gauge} (Max minus Min) is {gauge}+ minus "
                         f"{gauge}-; give a gauge's in one form", line)


def _axis(path: Path, line: int, column: str, text: str) -> int:
    value = text.strip().lower()
    if value not in AXES:
        raise InputError(path, f"{column}: {text.strip()!r} is not one of x, y, z", line)
    return AXES.index(value)


_AXIS_CODE = {a: k for k, a in enumerate(AXES)}
_NUMBER_COLUMNS = ("t_s", "tcp_x", "tcp_y", "tcp_z", "q_x", "q_y", "q_z", "reading_mm")


def _checked_row(path: Path, line: int, row: list[str], header: list[str], at: dict[str, int],
                 has_approach: bool) -> None:
    """Refuse one row, naming its first problem: the one definition of a valid row's
    messages (the vectorised reader checks all rows at once, then asks this for the
    words and the line)."""
    if _misfit(row, header):
        raise InputError(path, _fields_problem(row, header), line)
    leg = _axis(path, line, "leg", row[at["leg"]])
    gauge = _axis(path, line, "gauge_axis", row[at["gauge_axis"]])
    if gauge == leg:
        raise InputError(path, f"gauge_axis {AXES[gauge]} equals leg: a gauge measures "
                         "across its leg, along one of the two other axes", line)
    cycle_text = row[at["cycle"]].strip()
    if _cycle(cycle_text) < 1:
        shown = cycle_text[:40] + ("..." if len(cycle_text) > 40 else "")
        raise InputError(path, f"cycle: {shown!r} is not a whole number 1..{MAX_CYCLE}", line)
    for c in _NUMBER_COLUMNS:
        _number(path, line, c, row[at[c]])
    if has_approach:
        for c in APPROACH_COLUMNS:
            v = _number(path, line, c, row[at[c]])
            if v not in (-1.0, 0.0, 1.0):
                raise InputError(path, f"{c}: {v:g} is not -1, 0 or 1", line)


def _cycle(text: str) -> int:
    """A repeat index written in ASCII digits within bounds, else 0."""
    if not (text.isascii() and text.isdigit()) or len(text) > len(str(MAX_CYCLE)):
        return 0
    value = int(text)
    return value if value <= MAX_CYCLE else 0


def _numbers(texts: tuple[str, ...]) -> np.ndarray:
    """The values of a column of numbers as :func:`_number` reads one (NaN where it
    would refuse the text)."""
    return np.array([_ascii_float(t) for t in texts])


def _bad(column: str, values: np.ndarray) -> np.ndarray:
    """Which values :func:`_number` refuses: not finite, or beyond the column's bound."""
    bad = ~np.isfinite(values)
    bound = _BOUNDS.get(column)
    if bound is not None:
        with np.errstate(invalid="ignore"):
            bad |= np.abs(values) > bound
    return bad


@dataclass(frozen=True)
class _ColumnsAt:
    """Where each column of a readings header is."""

    at: dict[str, int]
    has_approach: bool  # all three approach columns

    @classmethod
    def of(cls, header: Sequence[str]) -> _ColumnsAt:
        at = {c: header.index(c) for c in (*READINGS_COLUMNS, *APPROACH_COLUMNS) if c in header}
        return cls(at, all(c in at for c in APPROACH_COLUMNS))

    @property
    def numbers(self) -> tuple[str, ...]:
        """The columns read as numbers."""
        return _NUMBER_COLUMNS + (APPROACH_COLUMNS if self.has_approach else ())


@dataclass(frozen=True)
class _Columns:
    """The readings' columns decoded, a refused cell as a code below 0 (leg, gauge,
    cycle) or NaN (numbers); :meth:`flagged` says which rows hold one."""

    leg: np.ndarray
    gauge: np.ndarray
    cycle: np.ndarray
    numbers: dict[str, np.ndarray]  # each number column read
    approach: np.ndarray | None  # (n, 3), when the file has the approach columns

    def flagged(self) -> np.ndarray:
        """The rows :func:`_checked_row` refuses."""
        bad = (self.leg < 0) | (self.gauge < 0) | (self.leg == self.gauge) | (self.cycle < 1)
        for c, values in self.numbers.items():
            bad |= _bad(c, values)
        if self.approach is not None:
            a = self.approach
            bad |= np.any((a != -1.0) & (a != 0.0) & (a != 1.0), axis=1)
        return bad

    def table(self, lines: np.ndarray) -> ReadingsTable:
        n = self.numbers
        return ReadingsTable(
            t_s=n["t_s"], cycle=self.cycle, leg=self.leg, gauge_axis=self.gauge,
            tcp_mm=np.column_stack([n[c] for c in ("tcp_x", "tcp_y", "tcp_z")]),
            q_mm=np.column_stack([n[c] for c in ("q_x", "q_y", "q_z")]),
            reading_mm=n["reading_mm"],
            approach=self.approach.astype(int) if self.approach is not None else None,
            lines=lines)


def read_readings(path: str | Path) -> ReadingsTable:
    """The readings CSV, converted column by column (a campaign can hold 100,000 rows).
    A plain file (ASCII, unquoted, one row a line, as ogacq and spreadsheets write it)
    of more than SMALL_FILE_ROWS rows is read by numpy's C reader whole; anything else,
    or a plain file with a problem, row by row, where a row any check flags is handed
    to :func:`_checked_row`, which raises the first flagged row's problem with its line.
    The two give the same table bit for bit (tests/io/test_readings_csv.py)."""
    path = Path(path)
    try:
        text = read_text(path)
    except OSError as exc:
        raise InputError(path, f"cannot read: {exc.strerror or exc}") from None
    check_line_ends(path, text)
    plain = _plain_table(text) if text.count("\n") > SMALL_FILE_ROWS else None
    table = plain if plain is not None else _table_by_rows(path, text)
    _check_repeats(path, table)
    _check_gauge_travel(path, table)
    return table


def _check_repeats(path: Path, table: ReadingsTable) -> None:
    """Refuse a row that copies another: the same gauge at the same time, posture,
    cycle and reading (a spreadsheet's rows pasted twice) would count as one more
    repeat of the measurement. Rows that share a time only are left alone: a
    hand-made file may write coarse times. A file whose times are all equal records
    none: not checked."""
    t = table.t_s
    if len(t) < 2 or np.all(t == t[0]):
        return
    columns = (t, table.leg, table.gauge_axis, table.cycle, *table.q_mm.T, table.reading_mm)
    order = np.lexsort((table.lines, *reversed(columns)))
    same = np.ones(len(t) - 1, dtype=bool)
    for column in columns:
        same &= column[order[1:]] == column[order[:-1]]
    if same.any():
        later, earlier = order[1:][same], order[:-1][same]
        k = int(np.argmin(table.lines[later]))
        row, first = int(later[k]), int(earlier[k])
        raise InputError(path, f"gauge {Gauge.at(table.gauge_axis[row], table.leg[row]).key} "
                         f"read again at t_s {t[row]:g}, at the same posture, cycle and "
                         f"reading as at line {table.lines[first]}: a row is repeated "
                         "(copied twice?); remove the copy", int(table.lines[row]))


def _check_gauge_travel(path: Path, table: ReadingsTable) -> None:
    """Refuse a reading farther from its gauge's others (their median) than any
    indicator travels: a gauge's overflow or error value ("9999.999"), or a column
    not in mm. Named by its line; the span of a gauge's readings is checked with every
    input (``ogacq.identify.plausibility``)."""
    from ogacq.identify.plausibility import MAX_GAUGE_TRAVEL_MM

    codes = table.leg * len(AXES) + table.gauge_axis
    medians = np.zeros(len(codes))
    for code in range(len(AXES) ** 2):  # (np.unique of numbers imports numpy.ma)
        mine = codes == code
        if not mine.any():
            continue
        values = np.sort(table.reading_mm[mine])  # (so would np.median)
        medians[mine] = (values[(len(values) - 1) // 2] + values[len(values) // 2]) / 2
    far = np.abs(table.reading_mm - medians) > MAX_GAUGE_TRAVEL_MM
    if far.any():
        k = int(np.flatnonzero(far)[0])
        raise InputError(path, f"reading_mm: {table.reading_mm[k]:.10g} is "
                         f"{abs(table.reading_mm[k] - medians[k]):g} mm from gauge "
                         f"{Gauge.at(table.gauge_axis[k], table.leg[k]).key}'s median reading "
                         f"({medians[k]:g} mm), beyond the {MAX_GAUGE_TRAVEL_MM:g} mm travel "
                         "of any indicator: a gauge's overflow or error value (read it again, "
                         "or remove the row), or readings not in mm?", int(table.lines[k]))


# Below this, the row reader is the faster: numpy's reader costs ~5 ms the first time
# in a process (a 72-reading refit: 6 ms against 1 ms), and the two cross near 250
# rows once warm.
SMALL_FILE_ROWS = 200


# A plain file: its header, then rows with as many fields as it has, none quoted, no
# blank line between them (so that row k is line k + 2), every character ASCII (numpy's
# float reader also takes a non-breaking space, which _number refuses).
_BLANK_LINE = re.compile(r"\n[ \t]*(\n|$)")


@dataclass(frozen=True)
class _PlainFile:
    """A plain file cut into its header and rows."""

    header: list[str]
    body: str  # the rows, one a line
    n_rows: int


def _plain_file(text: str) -> _PlainFile | None:
    """``text`` cut into header and rows, if it is a plain file with the readings
    columns (those :func:`_rows` words a problem of are left to it)."""
    if not text.isascii() or '"' in text:
        return None
    text = text.replace("\r\n", "\n").removesuffix("\n")
    head, newline, body = text.partition("\n")
    if not newline or not body or _BLANK_LINE.search("\n" + body):
        return None
    header = [h.strip() for h in head.split(",")]
    if len(set(header)) != len(header) or not set(READINGS_COLUMNS) <= set(header) \
            or any(h.endswith(tuple(_OTHER_UNITS)) for h in header):
        return None
    n_rows = body.count("\n") + 1
    if body.count(",") != n_rows * (len(header) - 1):  # a row with a field more or less
        return None
    return _PlainFile(header, body, n_rows)


def _load_plain(plain: _PlainFile) -> _Columns | None:
    """The columns by numpy's C reader; None where it refuses a field."""
    where = _ColumnsAt.of(plain.header)
    at, wanted = where.at, where.numbers
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            words = np.loadtxt(io.StringIO(plain.body), delimiter=",", dtype=str, comments=None,
                               usecols=[at["leg"], at["gauge_axis"], at["cycle"]], ndmin=2)
            block = np.loadtxt(io.StringIO(plain.body), delimiter=",", dtype=float,
                               comments=None, usecols=[at[c] for c in wanted], ndmin=2)
    except ValueError:  # a field that is not a number, or rows of another width
        return None
    if words.shape[0] != plain.n_rows or block.shape[0] != plain.n_rows:
        return None
    leg, gauge = (_codes(words[:, k], _axis_code) for k in (0, 1))
    return _Columns(leg, gauge, _codes(words[:, 2], lambda t: _cycle(t.strip())),
                    {c: block[:, k] for k, c in enumerate(wanted)},
                    block[:, -3:] if where.has_approach else None)


def _plain_table(text: str) -> ReadingsTable | None:
    """The table of a plain file whose every row is valid, else None (the row-by-row
    reader then says which row and why)."""
    plain = _plain_file(text)
    columns = None if plain is None else _load_plain(plain)
    if plain is None or columns is None or columns.flagged().any():
        return None
    return columns.table(np.arange(2, plain.n_rows + 2))


def _axis_code(text: str) -> int:
    return _AXIS_CODE.get(text.strip().lower(), -1)


def _codes(words: np.ndarray, code: Callable[[str], int]) -> np.ndarray:
    """``code`` of each word, computed once per distinct word (a campaign's columns
    of letters and cycles hold a handful of them)."""
    distinct, inverse = np.unique(words, return_inverse=True)
    return np.array([code(str(w)) for w in distinct], dtype=int)[inverse.ravel()]


def _table_by_rows(path: Path, text: str) -> ReadingsTable:
    header, rows = _rows(path, READINGS_COLUMNS, text)
    where = _ColumnsAt.of(header)
    at = where.at
    fields = [row for _, row in rows]
    lines = np.array([line for line, _ in rows])
    misfits = np.array([_misfit(row, header) for row in fields])
    if misfits.any():  # short rows: pad them so that the columns can be cut; refused below
        fields = [row + [""] * (len(header) - len(row)) for row in fields]
    cells = list(zip(*fields, strict=False))  # extra trailing fields are ignored

    def column(name: str) -> tuple[str, ...]:
        return cells[at[name]]

    numbers = {c: _numbers(column(c)) for c in where.numbers}
    columns = _Columns(np.array([_axis_code(t) for t in column("leg")]),
                       np.array([_axis_code(t) for t in column("gauge_axis")]),
                       np.array([_cycle(t.strip()) for t in column("cycle")]), numbers,
                       np.column_stack([numbers[c] for c in APPROACH_COLUMNS])
                       if where.has_approach else None)
    for k in map(int, np.flatnonzero(misfits | columns.flagged())):
        _checked_row(path, int(lines[k]), rows[k][1], header, at, where.has_approach)
    return columns.table(lines)


def check_table_postures(table: ReadingsTable, machine: MachineSpec, path: str | Path,
                         margin_mm: float = 1.0) -> None:
    """Refuse rows whose joint coordinates the machine cannot take."""
    low, high = machine.rho_min_mm - margin_mm, machine.rho_max_mm + margin_mm
    bad = np.flatnonzero(np.any((table.q_mm < low) | (table.q_mm > high), axis=1))
    if len(bad):
        k = int(bad[0])
        raise InputError(path, f"posture outside the workspace: q = {_fmt(table.q_mm[k])} mm, "
                         f"limits {machine.rho_min_mm:g}..{machine.rho_max_mm:g} mm "
                         "(is the machine file the right one?)", int(table.lines[k]))
    # the commanded TCP is never farther from the zero posture than a leg and its travel
    reach = machine.leg_length_mm + max(abs(machine.rho_min_mm), abs(machine.rho_max_mm))
    bad = np.flatnonzero(np.any(np.abs(table.tcp_mm) > reach, axis=1))
    if len(bad):
        k = int(bad[0])
        raise InputError(path, f"TCP outside the workspace: tcp = {_fmt(table.tcp_mm[k])} mm, "
                         f"farther than the {reach:g} mm a leg and its travel reach "
                         "(is the machine file the right one?)", int(table.lines[k]))
    tcp = nominal_tcp(table.q_mm, machine.leg_length_mm)
    bad = np.flatnonzero(~np.all(np.isfinite(tcp), axis=1))
    if len(bad):
        k = int(bad[0])
        raise InputError(path, f"posture outside the workspace: the legs cannot reach a TCP "
                         f"at q = {_fmt(table.q_mm[k])} mm", int(table.lines[k]))


def _fmt(v: np.ndarray) -> str:
    return "(" + ", ".join(f"{x:.3f}" for x in v) + ")"


def write_readings(path: str | Path, layout: ReadingsLayout, readings_mm: np.ndarray) -> None:
    """The readings CSV of INTERCHANGE.md (plus the approach side, ignored by others)."""
    out = io.StringIO(newline="")
    w = csv.writer(out)
    w.writerow(READINGS_COLUMNS + APPROACH_COLUMNS)
    for k in range(len(layout)):
        row = [f"{layout.t_s[k]:.3f}", int(layout.cycle[k]), AXES[layout.leg[k]],
               AXES[layout.gauge_axis[k]], *(f"{v:.6f}" for v in layout.tcp_mm[k]),
               *(f"{v:.6f}" for v in layout.q_mm[k]), f"{readings_mm[k]:.6f}",
               *(int(v) for v in layout.approach[k])]
        w.writerow(row)
    # whole or not at all: a full disk leaves the file as it was (or none)
    write_atomically(path, out.getvalue().encode("utf-8"))
