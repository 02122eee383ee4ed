"""The plain CSV table, for any controller without a format of its own here.

One row per axis and nominal position: ``axis,nominal_mm,forward_mm,reverse_mm,U_mm``
with the errors (actual minus commanded, the AxisMap's sign: a controller corrects
by minus them) approached moving toward + and toward -, and U the expanded
uncertainty (k = 2) of the point, the larger of its two sides. Between nominals the
map is linear; ``#`` lines are comments (no source: ogacq's own layout, described in
docs/formats.md).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ogacq.compensation.tables import Applied, AxisTable, ControllerTables, figures_block
from ogacq.model.axis_map import AxisMap

FORMAT = "csv"
K = 2.0
HEADER = "axis,nominal_mm,forward_mm,reverse_mm,U_mm"


def _applied(m: AxisMap) -> Applied:
    def applied(x: np.ndarray, side: int) -> np.ndarray:
        return m.error_mm(x, side)

    return applied


def csv_tables(maps: Mapping[str, AxisMap], *, title: str = "") -> ControllerTables:
    axes = {a: AxisTable(a, m, _applied(m)) for a, m in maps.items()}
    lines = [f"# {title}" if title else "# ogacq compensation",
             "# errors, actual - commanded (mm), approached toward + (forward) and toward - "
             "(reverse); correct by minus them, linear between nominals; U: k = 2",
             *figures_block(axes, "#"), HEADER]
    for axis, m in maps.items():
        for q, f, r, uf, ur in zip(m.positions_mm, m.forward_mm, m.reverse_mm,
                                   m.u_forward_mm, m.u_reverse_mm, strict=True):
            lines.append(f"{axis},{q:.6f},{f:.6f},{r:.6f},{K * max(uf, ur):.6f}")
    return ControllerTables(FORMAT, {"compensation.csv": "\n".join(lines) + "\n"}, axes)
