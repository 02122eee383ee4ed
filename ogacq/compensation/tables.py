"""What every controller table shares: the table written from a map, and the
correction the controller then applies, from which the residual it leaves (and the
ISO 230-2 figures predicted after it) is computed.

``applied_mm(q, side)`` is in the map's sign: the error the controller takes away
(a controller adding a trim t to the command removes an error -t). The residual
at a target is ``map.error_mm - applied_mm``.
"""

from __future__ import annotations

import unicodedata
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from ogacq.compensation.iso230 import Iso230Figures, map_figures
from ogacq.errors import InputError
from ogacq.model.axis_map import AxisMap

Applied = Callable[[np.ndarray, int], np.ndarray]
K = 2.0  # the coverage factor of the U a table carries


class TableError(InputError, ValueError):
    """The map does not fit the format's limits, or an option of the format is not one
    it takes (the message says which and why); a ValueError as well, as its callers
    took it before it joined the root."""

    def __init__(self, problem: str) -> None:
        super().__init__(None, problem)


@dataclass(frozen=True)
class AxisTable:
    axis: str
    axis_map: AxisMap
    applied: Applied  # the error the controller removes at q from side +1/-1
    notes: tuple[str, ...] = ()
    # where the table's own correction changes: its points, and for a staircase the
    # position just before each step (the residual is largest there)
    probes_mm: tuple[float, ...] = ()
    # the distance between the table's points where the format spaces them evenly
    # (None: the map's own positions): what a finer grid would have to beat
    spacing_mm: float | None = None

    def targets(self) -> np.ndarray:
        """The targets the figures are computed at: the map's positions and the
        table's probes within them."""
        q = np.asarray(self.axis_map.positions_mm, float)
        probes = np.asarray(self.probes_mm, float)
        probes = probes[(probes >= q[0]) & (probes <= q[-1])]
        return np.unique(np.concatenate([q, probes]))

    def residual_map(self) -> AxisMap:
        """What is left after the controller's correction, at the targets, with the
        map's uncertainty (the table adds its rounding to the systematic part)."""
        m = self.axis_map
        q = self.targets()
        return AxisMap(m.axis, tuple(float(v) for v in q),
                       tuple(float(v) for v in m.error_mm(q, 1) - self.applied(q, 1)),
                       tuple(float(v) for v in m.error_mm(q, -1) - self.applied(q, -1)),
                       tuple(float(v) for v in np.interp(q, m.positions_mm, m.u_forward_mm)),
                       tuple(float(v) for v in np.interp(q, m.positions_mm, m.u_reverse_mm)),
                       m.reference_mm, "residual")

    def grid_residual_mm(self) -> float:
        """The most the table leaves of the map (its grid's interpolation, staircase,
        resampling or rounding), either side."""
        r = self.residual_map()
        return float(np.max(np.abs(np.concatenate([r.forward_mm, r.reverse_mm]))))

    def u_mm(self, q: np.ndarray, side: int) -> np.ndarray:
        """The table's expanded uncertainty (k = 2) at ``q``: the map's U there plus the
        most its grid leaves of the map (``uncertainty_block``)."""
        m = self.axis_map
        u = np.interp(q, m.positions_mm, m.u_forward_mm if side > 0 else m.u_reverse_mm)
        return K * u + self.grid_residual_mm()

    def before(self) -> Iso230Figures:
        return map_figures(self.axis_map, self.targets())

    def after(self) -> Iso230Figures:
        return map_figures(self.residual_map())


@dataclass(frozen=True)
class ControllerTables:
    """One format's files (name -> text) and its tables per axis."""

    format: str
    files: dict[str, str]
    axes: dict[str, AxisTable]
    notes: tuple[str, ...] = field(default_factory=tuple)


def figures_block(tables: dict[str, AxisTable], comment: str) -> list[str]:
    """The ISO 230-2 figures of each axis before and after its table, as comment lines."""
    lines = [f"{comment} ISO 230-2:2014 figures of each axis, from the map (s = its u, k = 1; "
             "not a repeat scatter):"]
    for axis, table in tables.items():
        lines.append(f"{comment}   {axis} before: {table.before().line()}")
        lines.append(f"{comment}   {axis} after (predicted, this table): {table.after().line()}")
    return lines


# Where a line ends for some reader of a controller file: LF, CR, VT, FF, NEL, the file,
# group and record separators, U+2028 and U+2029 (Python's str.splitlines, which follows
# Unicode's line boundaries: UAX #14 mandatory breaks). Each is replaced, never kept.
# Every other character that does not print (Unicode categories C*: controls, format
# characters such as U+202E that reorder what a screen shows, unassigned, private use,
# surrogates) is replaced too: a controller's editor shows such text unlike ogacq.
_NOT_PRINTED = ("Cc", "Cf", "Cn", "Co", "Cs", "Zl", "Zp")
MAX_TEXT = 200  # characters of a title or a comment kept (no source: one screen line)
REPLACEMENT = "?"


def one_line(text: str, forbidden: str = "") -> str:
    """``text`` as one printable line for a controller file: every line break and
    non-printing character, and each of the format's own ``forbidden`` characters
    (its comment and section marks), replaced by ``?``; cut at MAX_TEXT characters."""
    out = "".join(REPLACEMENT if unicodedata.category(c) in _NOT_PRINTED or c in forbidden
                  else c for c in text)
    return out[:MAX_TEXT]


def uncertainty_block(tables: Mapping[str, AxisTable], comment: str) -> list[str]:
    """Each map's expanded uncertainty (k = 2) at each of its points and each side, and
    what the table's grid leaves of the map between its own points, as comment lines:
    what a table whose format has no column for it carries. U is the map's, from the
    fit's covariance (``AxisMap``); the table's U at a position is it plus the grid's
    residual (a known deviation, added linearly: ``AxisTable.u_mm``)."""
    lines = [f"{comment} expanded uncertainty U (k = {K:g}) of the map, mm, from the fit's "
             "covariance: axis, position, U toward +, U toward -"]
    for axis, table in tables.items():
        m = table.axis_map
        lines += [f"{comment}   {axis} {q:.3f} {K * uf:.6f} {K * ur:.6f}"
                  for q, uf, ur in zip(m.positions_mm, m.u_forward_mm, m.u_reverse_mm,
                                       strict=True)]
        lines.append(f"{comment}   {axis}: between its points this table's grid leaves up to "
                     f"{table.grid_residual_mm():.6f} mm of the map: add it to U there")
    return lines
