"""What every controller table shares: the table written from a map, and the
correction the controller then applies, from which the residual it leaves (and the
ISO 230-2 figures predicted after it) is computed.

``applied_mm(q, side)`` is in the map's sign: the error the controller takes away
(a controller adding a trim t to the command removes an error -t). The residual
at a target is ``map.error_mm - applied_mm``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ogacq.compensation.iso230 import Iso230Figures, map_figures
from ogacq.errors import InputError
from ogacq.model.axis_map import AxisMap

Applied = Callable[[np.ndarray, int], np.ndarray]


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
