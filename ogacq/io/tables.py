"""Readings CSV and deviations CSV (INTERCHANGE.md): strict readers, one writer.

Every problem is reported with the file, the line and what is wrong; nothing is
guessed. Values are in mm: a column in another unit, or with none, is refused
rather than converted silently.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ogacq.identify.observations import Deviation
from ogacq.io.errors import InputError
from ogacq.io.text import decode_text, read_text
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


@dataclass
class ReadingsTable:
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
    """"readings", "deviations" or "session" from the file's first line."""
    path = Path(path)
    try:
        with path.open("rb") as fh:
            first = decode_text(fh.readline(), path)
    except OSError as exc:
        raise InputError(path, f"cannot read: {exc.strerror or exc}") from None
    if first.lstrip().startswith("{"):
        return "session"
    header = {h.strip() for h in next(csv.reader([first]), [])}
    if "name" in header:
        return "deviations"
    if header & {"leg", "gauge_axis"}:
        return "readings"
    raise InputError(path, "unrecognised header: expected a readings CSV "
                     f"({', '.join(READINGS_COLUMNS)}) or a deviations CSV (name,value_mm)", 1)


def _rows(path: Path, required: Sequence[str]) -> tuple[list[str], list[tuple[int, list[str]]]]:
    try:
        reader = csv.reader(io.StringIO(read_text(path), newline=""))
        header = [h.strip() for h in next(reader, [])]
        rows = [(reader.line_num, row) for row in reader if any(c.strip() for c in row)]
    except OSError as exc:
        raise InputError(path, f"cannot read: {exc.strerror or exc}") from None
    except csv.Error as exc:
        raise InputError(path, f"not a readable CSV file: {exc}") from None
    if not header:
        raise InputError(path, "empty file: no header row", 1)
    for col in header:
        for suffix, unit in _OTHER_UNITS.items():
            if col.endswith(suffix) and col[: -len(suffix)] + "_mm" in required:
                raise InputError(path, f"column {col!r} is in {unit}; this format takes mm: "
                                 f"convert and name it {col[: -len(suffix)]}_mm", 1)
    missing = [c for c in required if c not in header]
    if missing:
        col = missing[0]
        if col.endswith("_mm") and col[:-3] in header:
            raise InputError(path, f"column {col[:-3]!r} has no unit: values must be in mm and "
                             f"the column named {col!r}", 1)
        raise InputError(path, f"missing column {col!r} (header has: {', '.join(header)})", 1)
    if len(set(header)) != len(header):
        dup = next(h for h in header if header.count(h) > 1)
        raise InputError(path, f"column {dup!r} appears twice in the header", 1)
    if not rows:
        raise InputError(path, "no data rows after the header", 2)
    return header, rows


def _number(path: Path, line: int, column: str, text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise InputError(path, f"{column}: {text.strip()!r} is not a number", line) from None
    if not math.isfinite(value):
        raise InputError(path, f"{column}: {text.strip()!r} is not a finite number", line)
    return value


def read_deviations(path: str | Path) -> list[tuple[str, float]]:
    path = Path(path)
    header, rows = _rows(path, DEVIATIONS_COLUMNS)
    at = {c: header.index(c) for c in DEVIATIONS_COLUMNS}
    out: list[tuple[str, float]] = []
    seen: dict[str, int] = {}
    for line, row in rows:
        if len(row) < len(header):
            raise InputError(path, f"row has {len(row)} fields, the header {len(header)}", line)
        name = row[at["name"]].strip()
        try:
            Deviation.parse(name)
        except ValueError:
            raise InputError(path, f"{name!r} is not a deviation name: expected dX_Y+, dX_Y- "
                             "(relative to Zero) or dX_Y (Max minus Min), X != Y in x, y, z",
                             line) from None
        if name in seen:
            raise InputError(path, f"{name} appears twice (first at line {seen[name]})", line)
        seen[name] = line
        out.append((name, _number(path, line, "value_mm", row[at["value_mm"]])))
    return out


def _axis(path: Path, line: int, column: str, text: str) -> int:
    value = text.strip().lower()
    if value not in AXES:
        raise InputError(path, f"{column}: {text.strip()!r} is not one of x, y, z", line)
    return AXES.index(value)


def read_readings(path: str | Path) -> ReadingsTable:
    path = Path(path)
    header, rows = _rows(path, READINGS_COLUMNS)
    at = {c: header.index(c) for c in (*READINGS_COLUMNS, *APPROACH_COLUMNS) if c in header}
    has_approach = all(c in at for c in APPROACH_COLUMNS)
    cols: dict[str, list] = {c: [] for c in (*READINGS_COLUMNS, *APPROACH_COLUMNS, "line")}
    for line, row in rows:
        if len(row) < len(header):
            raise InputError(path, f"row has {len(row)} fields, the header {len(header)}", line)
        leg = _axis(path, line, "leg", row[at["leg"]])
        gauge = _axis(path, line, "gauge_axis", row[at["gauge_axis"]])
        if gauge == leg:
            raise InputError(path, f"gauge_axis {AXES[gauge]} equals leg: a gauge measures "
                             "across its leg, along one of the two other axes", line)
        cycle_text = row[at["cycle"]].strip()
        if not cycle_text.isdigit() or int(cycle_text) < 1:
            raise InputError(path, f"cycle: {cycle_text!r} is not a whole number >= 1", line)
        cols["leg"].append(leg)
        cols["gauge_axis"].append(gauge)
        cols["cycle"].append(int(cycle_text))
        for c in ("t_s", "tcp_x", "tcp_y", "tcp_z", "q_x", "q_y", "q_z", "reading_mm"):
            cols[c].append(_number(path, line, c, row[at[c]]))
        if has_approach:
            for c in APPROACH_COLUMNS:
                v = _number(path, line, c, row[at[c]])
                if v not in (-1.0, 0.0, 1.0):
                    raise InputError(path, f"{c}: {v:g} is not -1, 0 or 1", line)
                cols[c].append(int(v))
        cols["line"].append(line)
    return ReadingsTable(
        t_s=np.array(cols["t_s"]), cycle=np.array(cols["cycle"]), leg=np.array(cols["leg"]),
        gauge_axis=np.array(cols["gauge_axis"]),
        tcp_mm=np.column_stack([cols["tcp_x"], cols["tcp_y"], cols["tcp_z"]]),
        q_mm=np.column_stack([cols["q_x"], cols["q_y"], cols["q_z"]]),
        reading_mm=np.array(cols["reading_mm"]),
        approach=np.column_stack([cols[c] for c in APPROACH_COLUMNS]) if has_approach else None,
        lines=np.array(cols["line"]))


def check_table_postures(table: ReadingsTable, machine: MachineSpec, path: str | Path,
                         margin_mm: float = 1.0) -> None:
    """Refuse rows whose joint coordinates the machine cannot take."""
    low, high = machine.rho_min_mm - margin_mm, machine.rho_max_mm + margin_mm
    bad = np.flatnonzero(np.any((table.q_mm < low) | (table.q_mm > high), axis=1))
    if len(bad):
        k = bad[0]
        raise InputError(path, f"posture outside the workspace: q = {_fmt(table.q_mm[k])} mm, "
                         f"limits {machine.rho_min_mm:g}..{machine.rho_max_mm:g} mm "
                         "(is the machine file the right one?)", int(table.lines[k]))
    tcp = nominal_tcp(table.q_mm, machine.leg_length_mm)
    bad = np.flatnonzero(~np.all(np.isfinite(tcp), axis=1))
    if len(bad):
        k = bad[0]
        raise InputError(path, f"posture outside the workspace: the legs cannot reach a TCP "
                         f"at q = {_fmt(table.q_mm[k])} mm", int(table.lines[k]))


def _fmt(v: np.ndarray) -> str:
    return "(" + ", ".join(f"{x:.3f}" for x in v) + ")"


def write_readings(path: str | Path, layout: ReadingsLayout, readings_mm: np.ndarray,
                   with_approach: bool = True) -> None:
    """The readings CSV of INTERCHANGE.md (plus the approach side, ignored by others)."""
    header = list(READINGS_COLUMNS) + (list(APPROACH_COLUMNS) if with_approach else [])
    with Path(path).open("w", encoding="utf-8", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        for k in range(len(layout)):
            row = [f"{layout.t_s[k]:.3f}", int(layout.cycle[k]), AXES[layout.leg[k]],
                   AXES[layout.gauge_axis[k]], *(f"{v:.6f}" for v in layout.tcp_mm[k]),
                   *(f"{v:.6f}" for v in layout.q_mm[k]), f"{readings_mm[k]:.6f}"]
            if with_approach:
                row += [int(v) for v in layout.approach[k]]
            w.writerow(row)
