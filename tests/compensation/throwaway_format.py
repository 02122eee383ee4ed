"""A throwaway table format, whole in this one module: its writer, its options, its
grid, its sign and its sanitiser. Nothing else in the project names it;
``tests/compensation/test_table_formats.py`` registers :data:`FORMAT` and runs it
through a campaign file and the export, which shows that adding a format is one module
and its tests.

The file (made up for the test, no source): ``! title`` on top, then one line per
point ``AXIS P<position> C<correction>`` with the correction (minus the error, forward
side only) held from one point to the next (a staircase), points every
``ThrowawayOptions.step_mm``, at most ``max_points`` per axis.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np

from ogacq.compensation.formats import GridLimits, TableFormat
from ogacq.compensation.tables import AxisTable, ControllerTables, TableError, one_line
from ogacq.model.axis_map import AxisMap

NAME = "throwaway"
SIGN = "C is the correction, minus the error (actual - commanded), held to the next point"


@dataclass(frozen=True)
class ThrowawayOptions:
    step_mm: float = 4.0
    max_points: int = 100


def safe_text(text: str) -> str:
    return one_line(text, "!")  # "!" starts the file's only comment line


def _staircase(q: np.ndarray, correction: np.ndarray):
    def applied(x: np.ndarray, side: int) -> np.ndarray:
        k = np.clip(np.searchsorted(q, np.asarray(x, float) + 1e-9, side="right") - 1,
                    0, len(q) - 1)
        return -correction[k]  # the error removed: minus the correction

    return applied


def write(maps: Mapping[str, AxisMap], options: ThrowawayOptions, *,
          title: str = "") -> ControllerTables:
    lines = [f"! {safe_text(title)} ({SIGN})"]
    axes = {}
    for axis, m in maps.items():
        lo, hi = m.positions_mm[0], m.positions_mm[-1]
        count = math.ceil((hi - lo) / options.step_mm - 1e-9) + 1
        if count > options.max_points:
            raise TableError(f"axis {axis}: {count} points, more than {options.max_points}")
        q = lo + options.step_mm * np.arange(count)
        correction = np.round(-m.error_mm(q, 1), 6)
        lines += [f"{axis.upper()} P{p:.3f} C{c:+.6f}" for p, c in zip(q, correction,
                                                                       strict=True)]
        axes[axis] = AxisTable(axis, m, _staircase(q, correction),
                               probes_mm=tuple(np.concatenate([q, q - 1e-6])),
                               spacing_mm=options.step_mm)
    return ControllerTables(NAME, {"table.txt": "\n".join(lines) + "\n"}, axes)


FORMAT = TableFormat(
    NAME, write, (ThrowawayOptions(),),
    GridLimits(ThrowawayOptions.max_points, "every step_mm", 0.5, "no source (a test's)",
               lambda o, mm: replace(o, step_mm=mm, max_points=10**6)),
    SIGN, safe_text)
