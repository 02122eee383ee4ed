"""LinuxCNC's joint compensation file (``[JOINT_n] COMP_FILE``).

Written from the LinuxCNC documentation, "INI Configuration", section [JOINT_n]
(docs/src/config/ini-config.adoc, entries BACKLASH, COMP_FILE, COMP_FILE_TYPE):

* one triplet per line, separated by spaces: the nominal (commanded) position,
  then two values whose meaning ``COMP_FILE_TYPE`` gives; machine units;
* type 0: the actual position moving in the positive direction, then in the
  negative; type 1: the offset from nominal while travelling in the positive
  direction, then in the negative (its example: ``-1.000 0.005 -0.005``);
* points between nominals are interpolated; the file starts with the smallest
  nominal, ascending; at most 256 triplets per joint;
* a ``COMP_FILE_TYPE`` for each ``COMP_FILE``; with a ``COMP_FILE`` the joint's
  ``BACKLASH`` is not used.

How the offsets act (the same documentation's type 1 wording, and LinuxCNC's
motion module: the trim for the direction of travel is added to the commanded
position, linear between nominals, the end values held beyond them): a trim t
removes an error -t, so ogacq writes type 1 with trims ``-e+`` and ``-e-``
(``AxisMap`` errors are actual minus commanded). The table file holds triplets
only: LinuxCNC's loader stops at the first line that is not three numbers, so the
notes and figures go into the INI fragment beside it.

Text in the INI fragment (the title, what a map is made of) is one comment line
(``safe_text``): INI comments are whole lines starting with ``;`` or ``#`` (the same
documentation, "INI File Layout"), so a line break would start a line LinuxCNC reads
as a section or a variable; a backslash is replaced too (no source for LinuxCNC's
reader: some INI readers join a line ending in one to the next).
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
from ogacq.model.units import UM_PER_MM

MAX_TRIPLETS = 256  # "the limit inside LinuxCNC is for 256 triplets per joint"
FORMAT = "linuxcnc"
DECIMALS = 6  # mm: a nanometre, below any table's meaning
SIGN = ("type 1: each offset is added to the commanded position, so it is minus the error "
        "(actual - commanded)")
SIGN_TYPE_0 = "type 0: each value is the actual position, the nominal plus the error"


def safe_text(text: str) -> str:
    """``text`` as the rest of one INI comment line (the module's docstring)."""
    return one_line(text, "\\")


@dataclass(frozen=True)
class LinuxCncOptions:
    joints: Mapping[str, int] | None = None  # axis -> joint number (default x 0, y 1, z 2)
    max_triplets: int = MAX_TRIPLETS
    file_type: int = 1  # COMP_FILE_TYPE: 1 offsets (trims), 0 actual positions
    spacing_mm: float | None = None  # nominals evenly this far apart (None: the map's)


def _nominals(m: AxisMap, limit: int, spacing_mm: float | None = None) -> np.ndarray:
    q = np.asarray(m.positions_mm, float)
    if spacing_mm is not None:
        limit = min(limit, math.ceil((q[-1] - q[0]) / spacing_mm - 1e-9) + 1)
    elif len(q) <= limit:
        return q
    # resampled evenly over the same range: the residual figures show what it costs
    return np.linspace(q[0], q[-1], max(2, limit))


def triplets(m: AxisMap, limit: int = MAX_TRIPLETS, file_type: int = 1,
             spacing_mm: float | None = None) -> list[tuple[float, float, float]]:
    """Type 1: nominal, trim travelling +, trim travelling - (trim = -error); type 0:
    nominal, actual position travelling +, travelling - (nominal + error)."""
    if file_type not in (0, 1):
        raise TableError(f"COMP_FILE_TYPE is 0 or 1, not {file_type}")
    q = _nominals(m, limit, spacing_mm)
    sign = 1.0 if file_type == 0 else -1.0
    base = q if file_type == 0 else np.zeros_like(q)
    fwd, rev = base + sign * m.error_mm(q, 1), base + sign * m.error_mm(q, -1)
    return [(round(float(a), DECIMALS), round(float(f), DECIMALS), round(float(r), DECIMALS))
            for a, f, r in zip(q, fwd, rev, strict=True)]


def _applied(rows: list[tuple[float, float, float]], file_type: int) -> Applied:
    """The error the controller removes: minus its trim (type 0's loader takes the trim
    as nominal minus actual, LinuxCNC's usrmotLoadComp)."""
    q, fwd, rev = np.array(rows).T
    if file_type == 0:
        fwd, rev = q - fwd, q - rev

    def applied(x: np.ndarray, side: int) -> np.ndarray:
        return -np.interp(x, q, fwd if side > 0 else rev)

    return applied


def linuxcnc_tables(maps: Mapping[str, AxisMap], options: LinuxCncOptions = LinuxCncOptions(),
                    *, title: str = "") -> ControllerTables:
    joints = dict(options.joints or {"x": 0, "y": 1, "z": 2})
    files: dict[str, str] = {}
    axes: dict[str, AxisTable] = {}
    kind = ("type 1, nominal / offset travelling + / offset travelling -, mm; the offset is "
            "added to the commanded position, so it is minus the error (actual - commanded)"
            if options.file_type == 1 else
            "type 0, nominal / actual position travelling + / travelling -, mm")
    ini = [f"; {safe_text(title)}" if title else "; ogacq compensation",
           f"; LinuxCNC joint compensation (INI Configuration, [JOINT_n] COMP_FILE): {kind}",
           f"; sign: {SIGN if options.file_type == 1 else SIGN_TYPE_0}"]
    for axis, m in maps.items():
        if axis not in joints:
            raise TableError(f"axis {axis}: no joint number given for LinuxCNC")
        rows = triplets(m, options.max_triplets, options.file_type, options.spacing_mm)
        if len(rows) > options.max_triplets:
            raise TableError(f"axis {axis}: {len(rows)} triplets, LinuxCNC takes at most "
                             f"{options.max_triplets} per joint")
        name = f"{axis}.comp"
        files[name] = "".join(f"{a:.{DECIMALS}f} {f:.{DECIMALS}f} {r:.{DECIMALS}f}\n"
                              for a, f, r in rows)
        reversal = float(np.mean(m.error_mm(np.asarray(m.positions_mm), -1)
                                 - m.error_mm(np.asarray(m.positions_mm), 1)))
        notes = (f"BACKLASH is not used while COMP_FILE is set: the reversal (mean "
                 f"{reversal * UM_PER_MM:.1f} µm) is in the table",)
        resampled = len(rows) < len(m.positions_mm) or options.spacing_mm is not None
        axes[axis] = AxisTable(axis, m, _applied(rows, options.file_type), notes,
                               probes_mm=tuple(r[0] for r in rows),
                               spacing_mm=(rows[1][0] - rows[0][0]) if resampled else None)
        ini += ["", f"[JOINT_{joints[axis]}]", f"; axis {axis}: {safe_text(m.source or 'map')}",
                f"COMP_FILE = {name}", f"COMP_FILE_TYPE = {options.file_type}",
                f"; {notes[0]} (a BACKLASH = {reversal:.4f} alone would correct its mean only)"]
    ini += ["", *figures_block(axes, ";"), *uncertainty_block(axes, ";")]
    files["linuxcnc.ini"] = "\n".join(ini) + "\n"
    return ControllerTables(FORMAT, files, axes)
