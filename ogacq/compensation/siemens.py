"""SINUMERIK 840D measuring system error compensation (leadscrew error, LEC/MSEC):
``$AA_ENC_COMP`` with ``_STEP``, ``_MIN``, ``_MAX`` and ``_IS_MODULO``.

Written from SINUMERIK 840D sl Function Manual "Extended Functions", K3
Compensation, section "Interpolatory compensation" (6FC5397-1BP20-0BA0, 09/2009,
5.4; 6FC5397-1BP40-3BA1, 03/2013, 4.4) and the SINUMERIK 808D parameter and
function manuals (MD32450 BACKLASH):

* the table is a file ``%_N_AX_EEC_INI`` with ``CHANDATA(1)``, one
  ``$AA_ENC_COMP[e,N,AXIS]`` per interpolation point N = 0, 1, ... (e the
  measuring system, 0 the first), ``$AA_ENC_COMP_STEP[e,AXIS]`` the distance
  between points, ``$AA_ENC_COMP_MIN`` / ``_MAX`` where the compensation starts and
  ends, ``$AA_ENC_COMP_IS_MODULO`` 0 for a linear axis, and ``M17`` at the end
  (the manual's example: STEP 1.0, MIN -200, MAX 600, 801 points); comments after
  ``;``; values in mm;
* points are equidistant: N runs 0..(MAX - MIN) / STEP; the control must be
  configured for at least that many (MD38000 $MA_MM_ENC_COMP_MAX_POINTS; the 808D
  holds 200, N = 0..199: the default limit here);
* the compensation value at the reference point should be zero, so that nothing
  jumps when the compensation becomes active after referencing;
* the compensation modifies the actual position value, linear between the points:
  "a positive compensation value causes the machine axis to move in the negative
  direction", so the value is the error itself (actual minus commanded), the
  AxisMap's sign;
* the table is one per measuring system, not per direction: the reversal goes to
  MD32450 $MA_BACKLASH, positive when the encoder leads the machine part (lost
  motion, the normal case), here the map's mean reversal; the table holds the
  forward errors, on the assumption that the backlash compensation brings the
  negative direction onto them (what varies of the reversal along the travel stays,
  and the predicted figures show it).
* "The size of the compensation value is not limited" (6FC5397-1BP40-3BA1, 4.4.2):
  the format bounds no value; ogacq's plausibility bound applies
  (``ogacq.compensation.formats``).

Text (the title) is one comment line (``safe_text``): a line break would make it a
line of the file, and ``%`` (``%_N_`` starts a file or a section of an archive) and
``;`` (a comment) are replaced as well.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ogacq.compensation.tables import (
    Applied,
    AxisTable,
    ControllerTables,
    TableError,
    figures_block,
    one_line,
    uncertainty_block,
)
from ogacq.model.axis_map import AxisMap

FORMAT = "siemens"
DECIMALS = 6
SIGN = "each value is the error itself (actual - commanded), which the control subtracts"


def safe_text(text: str) -> str:
    """``text`` as the rest of one ``;`` comment line (the module's docstring)."""
    return one_line(text, "%;")


@dataclass(frozen=True)
class SiemensOptions:
    axis_names: Mapping[str, str] | None = None  # default X1, Y1, Z1
    encoder: int = 0  # the measuring system (0: the first)
    step_mm: float | None = None  # None: the smallest whole mm within max_points
    max_points: int = 200


@dataclass(frozen=True)
class SiemensAxis:
    axis: str
    name: str
    minimum_mm: float
    step_mm: float
    values_mm: tuple[float, ...]  # N = 0..
    backlash_mm: float

    @property
    def maximum_mm(self) -> float:
        return round(self.minimum_mm + (len(self.values_mm) - 1) * self.step_mm, 9)

    def positions_mm(self) -> np.ndarray:
        return self.minimum_mm + self.step_mm * np.arange(len(self.values_mm))


def siemens_axis(m: AxisMap, options: SiemensOptions, name: str) -> SiemensAxis:
    ref, lo, hi = m.reference_mm, m.positions_mm[0], m.positions_mm[-1]
    step = options.step_mm or float(max(1, math.ceil((hi - lo) / (options.max_points - 1)
                                                     - 1e-9)))
    # the reference on a point, so that its value is the map's zero exactly
    below = math.ceil((ref - lo) / step - 1e-9)
    above = math.ceil((hi - ref) / step - 1e-9)
    count = below + above + 1
    if count > options.max_points:
        raise TableError(f"axis {m.axis}: {count} interpolation points of {step:g} mm, more "
                         f"than the {options.max_points} configured: a larger step_mm (or "
                         "raise MD38000 and max_points)")
    q = ref + step * np.arange(-below, above + 1)
    values = tuple(round(float(v), DECIMALS) + 0.0 for v in m.error_mm(q, 1))
    reversal = float(np.mean(m.error_mm(q, -1) - m.error_mm(q, 1)))
    return SiemensAxis(m.axis, name, round(float(q[0]), 9), step, values,
                       round(reversal, DECIMALS))


def _applied(axis: SiemensAxis) -> Applied:
    q = axis.positions_mm()
    v = np.asarray(axis.values_mm)

    def applied(x: np.ndarray, side: int) -> np.ndarray:
        forward = np.interp(x, q, v)
        return forward if side > 0 else forward + axis.backlash_mm

    return applied


def siemens_tables(maps: Mapping[str, AxisMap], options: SiemensOptions = SiemensOptions(), *,
                   title: str = "") -> ControllerTables:
    names = dict(options.axis_names or {"x": "X1", "y": "Y1", "z": "Z1"})
    e = options.encoder
    axes: dict[str, AxisTable] = {}
    sheets = []
    for axis, m in maps.items():
        if axis not in names:
            raise TableError(f"axis {axis}: no SINUMERIK machine axis name given")
        sheet = siemens_axis(m, options, names[axis])
        sheets.append(sheet)
        axes[axis] = AxisTable(axis, m, _applied(sheet),
                               probes_mm=tuple(float(v) for v in sheet.positions_mm()),
                               spacing_mm=sheet.step_mm)
    lines = ["%_N_AX_EEC_INI", f"; {safe_text(title)}" if title else "; ogacq compensation",
             "; measuring system error compensation (K3, interpolatory compensation): the "
             "value is the error, actual - commanded, mm", f"; sign: {SIGN}", "CHANDATA(1)"]
    for s in sheets:
        lines.append(f"; axis {s.axis} -> {s.name}: {len(s.values_mm)} points, needs "
                     f"MD38000 $MA_MM_ENC_COMP_MAX_POINTS[{e}] >= {len(s.values_mm)}, "
                     f"MD32700 $MA_ENC_COMP_ENABLE[{e}] = 1")
        lines += [f"$AA_ENC_COMP[{e},{n},{s.name}]={v:.{DECIMALS}f}"
                  for n, v in enumerate(s.values_mm)]
        lines += [f"$AA_ENC_COMP_STEP[{e},{s.name}]={s.step_mm:.{DECIMALS}f}",
                  f"$AA_ENC_COMP_MIN[{e},{s.name}]={s.minimum_mm:.{DECIMALS}f}",
                  f"$AA_ENC_COMP_MAX[{e},{s.name}]={s.maximum_mm:.{DECIMALS}f}",
                  f"$AA_ENC_COMP_IS_MODULO[{e},{s.name}]=0",
                  f"; reversal: MD32450 $MA_BACKLASH[{e}] = {s.backlash_mm:.{DECIMALS}f} (axis "
                  f"{s.name}; positive: the encoder leads the machine part)"]
    lines += [*figures_block(axes, ";"), *uncertainty_block(axes, ";"), "M17"]
    return ControllerTables(FORMAT, {"AX_EEC.INI": "\n".join(lines) + "\n"}, axes)

