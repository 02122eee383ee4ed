"""The papers' linear calibration equations (2008, eq. 11).

The deviation along ``j`` of leg ``i`` at a posture of angle ``alpha`` is
``b drho_i + a drho_j - b dL_i - c dL_j`` with ``a = sin alpha``,
``b = (0.5 + sin alpha) tan alpha``, ``c = (0.5 + sin alpha) / cos alpha - 0.5``.
The six-equation form (Max minus Min) is the difference of two such rows.
Tests check these rows against the exact model's Jacobian at the nominal point.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ogacq.identify.observations import Deviation
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import AXES


def coefficients(alpha_rad: float) -> tuple[float, float, float]:
    """(a, b, c) of eq. 11 for a posture whose other legs make ``alpha`` with the axis."""
    s = math.sin(alpha_rad)
    return s, (0.5 + s) * math.tan(alpha_rad), (0.5 + s) / math.cos(alpha_rad) - 0.5


def _row(gauge_axis: int, leg: int, alpha_rad: float) -> np.ndarray:
    a, b, c = coefficients(alpha_rad)
    row = np.zeros(6)  # drho_x, drho_y, drho_z, dL_x, dL_y, dL_z
    row[leg] += b
    row[gauge_axis] += a
    row[3 + leg] -= b
    row[3 + gauge_axis] -= c
    return row


def design_matrix(deviation_names: Sequence[str], machine: MachineSpec,
                  angles_deg: tuple[float, float] | None = None) -> np.ndarray:
    """Rows of eq. 11 (or their Max-minus-Min differences) for the named deviations,
    columns ``joint_offset.x..z, leg_length.x..z``; the angles ``asin(rho / L)`` of
    Max and Min unless given (the 2008 paper printed rounded ones, 11.0 and -18.7 deg)."""
    if angles_deg is None:
        alpha_max, alpha_min = machine.alpha_max_rad, machine.alpha_min_rad
    else:
        alpha_max, alpha_min = (math.radians(a) for a in angles_deg)
    rows = []
    for name in deviation_names:
        deviation = Deviation.parse(name)
        up, down = (_row(*deviation.gauge.indices, alpha) for alpha in (alpha_max, alpha_min))
        rows.append({"+": up, "-": down, "": up - down}[deviation.sign])
    return np.array(rows)


LINEAR_COLUMNS = tuple(f"joint_offset.{a}" for a in AXES) + tuple(f"leg_length.{a}" for a in AXES)
