"""The plain CSV table, for any controller without a format of its own here.

One row per axis and nominal position:
``axis,nominal_mm,forward_mm,reverse_mm,U_mm,correction_forward_mm,correction_reverse_mm``
with the errors (actual minus commanded, the AxisMap's sign) approached moving
toward + and toward -, U the expanded uncertainty (k = 2) of the point (the larger
of its two sides, from the fit's covariance), and the corrections a controller adds
to the commanded position, minus the errors: the two last columns say the sign so
that nobody has to guess it. Between nominals the map is linear; ``#`` lines are
comments (no source: ogacq's own layout, described in docs/formats.md). Text in a
comment (the title) is one line (``safe_text``).
"""

from __future__ import annotations

from collections.abc import Mapping

from ogacq.compensation.tables import (
    AxisTable,
    ControllerTables,
    K,
    figures_block,
    one_line,
)
from ogacq.model.axis_map import AxisMap

FORMAT = "csv"
HEADER = ("axis,nominal_mm,forward_mm,reverse_mm,U_mm,correction_forward_mm,"
          "correction_reverse_mm")
SIGN = "correction = minus the error (actual - commanded), added to the commanded position"


def safe_text(text: str) -> str:
    """``text`` as the rest of one ``#`` comment line."""
    return one_line(text)


def csv_tables(maps: Mapping[str, AxisMap], options: None = None, *,
               title: str = "") -> ControllerTables:
    axes = {a: AxisTable(a, m, m.error_mm) for a, m in maps.items()}  # the map itself, applied
    lines = [f"# {safe_text(title)}" if title else "# ogacq compensation",
             "# errors, actual - commanded (mm), approached toward + (forward) and toward - "
             f"(reverse), linear between nominals; U: k = {K:g}", f"# sign: {SIGN}",
             *figures_block(axes, "#"), HEADER]
    for axis, m in maps.items():
        for q, f, r, uf, ur in zip(m.positions_mm, m.forward_mm, m.reverse_mm,
                                   m.u_forward_mm, m.u_reverse_mm, strict=True):
            lines.append(f"{axis},{q:.6f},{f:.6f},{r:.6f},{K * max(uf, ur):.6f},"
                         f"{-f + 0.0:.6f},{-r + 0.0:.6f}")
    return ControllerTables(FORMAT, {"compensation.csv": "\n".join(lines) + "\n"}, axes)
