"""Every table format chosen written into one folder, with the ISO 230-2 figures
beside, and only where the table does not make the axis worse.

``export_tables(folder, maps)`` writes one sub-folder per format of ``TABLE_FORMATS``
(``ogacq.compensation.formats``; all of them unless the campaign file chose some).
Each axis's table is judged before it is written: its values plausible and within
the format's bounds, the map beyond what its own band could hold from no error (else
correcting by it is expected to leave more than it takes), and the residual it
leaves, predicted on the format's own grid as the controller applies it, better than
no table (ISO 230-2 E smaller, A no larger). An axis whose table would be worse, or
would leave the error as it is (a grid whose points fall on the same phase of a
screw's period), is left out of that format and the reason said: for a grid too
coarse, the spacing the map would need. The folder is written whole into a temporary
folder beside it, then renamed: a crash leaves the old tables or the new ones, never
a mixture.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ogacq.compensation.formats import TABLE_FORMATS, TableFormat, known
from ogacq.compensation.iso230 import Iso230Figures
from ogacq.compensation.tables import AxisTable, TableError
from ogacq.io.atomic import fsync_folder, write_atomically
from ogacq.io.errors import StorageError
from ogacq.model.axis_map import AxisMap
from ogacq.model.units import UM_PER_MM

# Beyond this a table value is no error a machine in service has: the largest size the
# diagnosis finds plausible for a map (1 mm of hysteresis: each family's plausible_mm,
# ogacq/model/families/) and the library's 1 mm backlash. No source beyond those.
PLAUSIBLE_VALUE_MM = 1.0
# Figures closer than this are the same: far below any figure's meaning, above the
# floating point's noise.
SAME_MM = 1e-9
HALVINGS = 6  # finer grids tried, each half the last, for the spacing a map would need


@dataclass(frozen=True)
class AxisVerdict:
    """One axis of one format: written or not, why not, and the figures predicted."""

    axis: str
    written: bool
    reason: str | None = None
    before: Iso230Figures | None = None
    after: Iso230Figures | None = None

    def to_json(self) -> dict[str, Any]:
        return {"written": self.written, "reason": self.reason,
                "before": self.before.to_json() if self.before else None,
                "after": self.after.to_json() if self.after else None}


@dataclass(frozen=True)
class Exported:
    format: str
    files: tuple[Path, ...]
    figures: dict[str, dict[str, Any]]  # axis written -> {"before": ..., "after": ...}
    problem: str | None = None  # why an axis (or the whole format) was not written
    axes: dict[str, AxisVerdict] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        return {"format": self.format, "files": [str(f) for f in self.files],
                "figures": self.figures, "problem": self.problem,
                "axes": {a: v.to_json() for a, v in self.axes.items()}}


def chosen_formats(names: tuple[str, ...] | None) -> tuple[TableFormat, ...]:
    """The formats named (None: every one registered), an unknown name refused."""
    if names is None:
        return tuple(TABLE_FORMATS.values())
    unknown = [n for n in names if n not in TABLE_FORMATS]
    if unknown:
        raise TableError(f"unknown table format {unknown[0]!r}; known: {known()}")
    return tuple(TABLE_FORMATS[n] for n in names)


def export_tables(folder: Path, maps: Mapping[str, AxisMap], *, title: str = "",
                  formats: tuple[str, ...] | None = None) -> list[Exported]:
    """Each format's tables of ``maps`` into ``folder/<format>/``, ``folder`` replaced
    whole (module docstring)."""
    chosen = chosen_formats(formats)
    folder.parent.mkdir(parents=True, exist_ok=True)
    staging = _staging_beside(folder)
    try:
        out = [_export(staging, folder, f, options, maps, title)
               for f in chosen for options in f.options]
        _replace(staging, folder)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return out


def _export(staging: Path, folder: Path, fmt: TableFormat, options: Any,
            maps: Mapping[str, AxisMap], title: str) -> Exported:
    verdicts = {a: judge(fmt, options, m, title) for a, m in maps.items()}
    carried = {a: maps[a] for a, v in verdicts.items() if v.written}
    refused = "; ".join(v.reason for v in verdicts.values() if v.reason) or None
    if not carried:
        return Exported(fmt.name, (), {}, refused, verdicts)
    try:
        (tables,) = fmt.tables(carried, title, options)
    except TableError as exc:  # the axes together, when each alone fitted: said all the same
        why = f"{fmt.name}: {exc}"
        return Exported(fmt.name, (), {}, why, {a: replace(v, written=False, reason=v.reason
                                                           or why) for a, v in verdicts.items()})
    (staging / fmt.name).mkdir(exist_ok=True)
    for name, text in tables.files.items():
        write_atomically(staging / fmt.name / name, text.encode("utf-8"))
    figures = {a: {"before": t.before().to_json(), "after": t.after().to_json()}
               for a, t in tables.axes.items()}
    return Exported(fmt.name, tuple(folder / fmt.name / n for n in tables.files), figures,
                    refused, verdicts)


def judge(fmt: TableFormat, options: Any, m: AxisMap, title: str = "") -> AxisVerdict:
    """Whether ``fmt`` may hold the map of one axis: its values plausible and within
    the format's bound, and the table not worse than none (module docstring)."""
    band = within_its_band(m)
    problem = _out_of_bounds(fmt, m) or (
        None if band is None else f"{fmt.name}: axis {m.axis}: {band}; not written")
    if problem is not None:
        return AxisVerdict(m.axis, False, problem)
    try:
        table = _table(fmt, options, m, title)
    except TableError as exc:
        return AxisVerdict(m.axis, False, f"{fmt.name}: {exc}")
    before, after = table.before(), table.after()
    if _carries(before, after):
        return AxisVerdict(m.axis, True, None, before, after)
    return AxisVerdict(m.axis, False, _why_not(fmt, options, m, title, table, before, after),
                       before, after)


def _table(fmt: TableFormat, options: Any, m: AxisMap, title: str) -> AxisTable:
    (tables,) = fmt.tables({m.axis: m}, title, options)
    return tables.axes[m.axis]


def _out_of_bounds(fmt: TableFormat, m: AxisMap) -> str | None:
    """A value no machine has, or one the format cannot hold: with the axis, the value
    and where."""
    values = [(abs(v), v, q) for column in (m.forward_mm, m.reverse_mm)
              for v, q in zip(column, m.positions_mm, strict=True)]
    size, value, q = max(values)
    bounds = [(PLAUSIBLE_VALUE_MM, "the most a machine in service could have: check the "
               "diagnosis")]
    if fmt.limits.max_value_mm is not None:
        bounds.append((fmt.limits.max_value_mm, f"the most a {fmt.name} value holds "
                       f"({fmt.limits.source})"))
    for bound, what in bounds:
        if size > bound:
            return (f"{fmt.name}: axis {m.axis}: an error of {value:.6g} mm at {q:g} mm in "
                    f"the map ({m.source or 'no source given'}) is beyond {bound:g} mm, "
                    f"{what}; not written")
    return None


def within_its_band(m: AxisMap) -> str | None:
    """Why ``m`` is not worth correcting (None: it is): a map that its own band could
    hold from no error at all. Corrected by it, an axis is left with the band's mean
    square (E[(e - m)^2] = u^2, the map unbiased); uncorrected, with the error's, of
    which the map's mean square less the band's is the unbiased estimate (E[m^2] = e^2
    + u^2). A correction is expected to help only where the map's mean square is more
    than twice its band's (k = 1), over the positions it is written at. A 5 µm cubic
    taken for a 0.7 µm lead seen over 16 mm of its joint, its band as wide, made the
    axis worse: 0.4 -> 1.6 µm rms (bench/table_coverage.py, seed 165). No source
    beyond that expectation. The maps file and every table format are judged by it
    (``calibration/compensate.py``, ``judge``)."""
    values = np.concatenate([m.forward_mm, m.reverse_mm])
    bands = np.concatenate([m.u_forward_mm, m.u_reverse_mm])
    mean_square, band_square = float(np.mean(values**2)), float(np.mean(bands**2))
    if mean_square > 2.0 * band_square:
        return None
    um = UM_PER_MM
    return (f"the map ({m.source or 'no source given'}) lies within its own band: rms "
            f"{np.sqrt(mean_square) * um:.2f} µm beside its band's "
            f"{np.sqrt(band_square) * um:.2f} µm (k = 1); corrected by it, the axis would "
            "be expected to keep more error than it has")


def _carries(before: Iso230Figures, after: Iso230Figures) -> bool:
    """The table takes some of the error away and makes no figure worse."""
    return after.E < before.E - SAME_MM and after.A <= before.A + SAME_MM


def _why_not(fmt: TableFormat, options: Any, m: AxisMap, title: str, table: AxisTable,
               before: Iso230Figures, after: Iso230Figures) -> str:
    um = UM_PER_MM
    words = (f"{fmt.name}: axis {m.axis}: its table is predicted no better than none (A "
             f"{before.A * um:.2f} -> {after.A * um:.2f} µm, E {before.E * um:.2f} -> "
             f"{after.E * um:.2f} µm); not written")
    spacing = table.spacing_mm
    if spacing is None or fmt.limits.finer is None:
        return words
    span = m.positions_mm[-1] - m.positions_mm[0]
    grid = f"the format's grid, {fmt.limits.spacing}, gives {spacing:g} mm over {span:g} mm"
    needed = needed_spacing(fmt, options, m, title, spacing)
    if needed is None:
        return (f"{words}: {grid}; no spacing down to {spacing / 2 ** HALVINGS:g} mm carries "
                f"the map ({m.source or 'no source given'})")
    return (f"{words}: the map ({m.source or 'no source given'}) needs a spacing <= "
            f"{needed:g} mm ({int(-(-span // needed)) + 1} points); {grid}")


def needed_spacing(fmt: TableFormat, options: Any, m: AxisMap, title: str,
                   spacing_mm: float) -> float | None:
    """The largest of ``spacing_mm`` / 2, / 4, ... whose table carries the map (None:
    none of them)."""
    assert fmt.limits.finer is not None
    for k in range(1, HALVINGS + 1):
        finer = spacing_mm / 2 ** k
        try:
            table = _table(fmt, fmt.limits.finer(options, finer), m, title)
        except TableError:
            continue
        if _carries(table.before(), table.after()):
            return finer
    return None


def _staging_beside(folder: Path) -> Path:
    """A new folder beside ``folder`` (a leftover of a crashed export removed first),
    with the permissions a plain mkdir gives."""
    staging = folder.with_name(f".{folder.name}.{os.getpid()}.tmp")
    shutil.rmtree(staging, ignore_errors=True)
    try:
        staging.mkdir()
    except OSError as exc:
        raise StorageError(staging, exc) from None
    return staging


def _replace(staging: Path, folder: Path) -> None:
    """``staging`` renamed ``folder``; an old ``folder`` moved aside first and removed
    after, the parent folder forced to the disk between."""
    old = staging.with_suffix(".old")
    shutil.rmtree(old, ignore_errors=True)
    try:
        if folder.exists():
            os.rename(folder, old)
        os.rename(staging, folder)
        fsync_folder(folder.parent)
    except OSError as exc:
        raise StorageError(folder, exc) from None
    shutil.rmtree(old, ignore_errors=True)
