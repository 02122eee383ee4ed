"""FANUC pitch error compensation: parameters 3620-3627 and the data per interval.

Written from FANUC's parameter descriptions (Series 0i-PB Parameter Manual
B-63980EN/01, section 4, parameters 3620-3624 and its example of the compensation
values of each position number; the Series 16i/18i technical report A-77810E,
"Bidirectional pitch error compensation", parameters 3605#0 and 3620-3627):

* the axis's travel is cut into intervals of 3624 (the pitch error compensation
  interval); compensation positions are numbered, 3620 being the reference
  position's, 3621 the farthest on the negative side and 3622 on the positive side,
  with 3621 = 3620 - (negative travel / interval) + 1 and 3622 = 3620 + (positive
  travel / interval) (the manual's example: reference 40, -400 mm, 50 mm -> 33);
* the value of position n is the compensation over the interval that ends at n
  (the section between n - 1 and n), an increment in the compensation unit: the
  detection unit times the magnification 3623. The absolute compensation at a
  position is the sum of the increments between the reference position and it:
  zero at the reference position;
* bidirectional compensation (3605#0 = 1) adds a table for travel in the negative
  direction, 3626 its farthest negative position number, and 3627 the absolute
  compensation at the reference position when it is approached in the direction
  opposite to the reference position return. Without it, the reversal is the
  backlash parameter 1851 (backlash compensating value, detection units).

Sign: FANUC outputs the compensation as pulses added to the motion, so its values
are the correction, minus the error (AxisMap: actual minus commanded). No source
states at which point of its interval the increment is output: ogacq takes the
value of position n as output when the axis passes position n, so between two
positions the compensation is that of the lower one, a staircase whose cost the
predicted figures include. No source either for the range of one value or the
number of positions per axis on a given control: ``FanucOptions`` holds them (the
defaults: -7..+7 per position, as the classic Series 0/16/18 pitch error screen
takes, and 128 positions per axis), to be set from the control's own manual.
The output is a sheet of parameters and values to key in (or to make a parameter
tape from): no tape format is written, for want of a source for it. Its text (the
title) is one ``#`` comment line (``safe_text``): a line break, and the characters
a FANUC tape gives a meaning to, ``%`` (the tape's start and end) and ``(`` ``)`` (a
comment's control-out and control-in), are replaced, so that a tape made from the
sheet cannot end or start inside a name (FANUC Series 16i/18i-PB Operator's Manual
B-63684EN/01, 13 "Program configuration": a block ends at LF; FANUC Data Server
Operator's Manual B-62694EN/03, "Format of NC program": ``%`` the tape start and end,
the program number ``O`` the block after it, comments in parentheses; an ``O`` only
counts at the start of a block, which a name without line breaks never is).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
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

FORMAT = "fanuc"
SIGN = "each value is an increment of the correction, minus the error (actual - commanded)"


def safe_text(text: str) -> str:
    """``text`` as the rest of one comment line of the sheet (the module's docstring)."""
    return one_line(text, "%()")


@dataclass(frozen=True)
class FanucOptions:
    detection_unit_mm: float = 0.001  # IS-B
    interval_mm: float | None = None  # None: the smallest whole mm within max_points
    max_points: int = 128  # per axis and direction (no source: the control's manual says)
    value_limit: int = 7  # |value| per position, in compensation units (no source)
    max_magnification: int = 100
    first_point: int = 0  # number of the first position used (3621 of the first axis)
    bidirectional: bool = True  # also the negative-direction table (3605#0 = 1)


@dataclass(frozen=True)
class FanucAxis:
    """One axis's parameters and increments as FANUC takes them."""

    axis: str
    reference_mm: float
    interval_mm: float
    magnification: int
    unit_mm: float  # compensation unit: detection unit x magnification
    ref_no: int  # 3620
    neg_no: int  # 3621
    pos_no: int  # 3622
    values: tuple[int, ...]  # positions neg_no..pos_no, increments in compensation units
    neg_dir_no: int | None = None  # 3626
    neg_values: tuple[int, ...] = ()  # negative-direction table, same positions
    ref_opposite: int = 0  # 3627, detection units
    backlash: int = 0  # 1851, detection units (when not bidirectional)

    def position_of(self, number: int) -> float:
        return self.reference_mm + (number - self.ref_no) * self.interval_mm

    def absolute(self, values: tuple[int, ...]) -> np.ndarray:
        """The absolute compensation (compensation units) at positions neg_no - 1 (the
        start of the first interval) to pos_no, summed from the reference position:
        0 there."""
        at = np.concatenate([[0], np.cumsum(np.asarray(values, int))])
        return at - at[self.ref_no - self.neg_no + 1]

    def positions_mm(self) -> np.ndarray:
        """Where positions neg_no - 1 .. pos_no are."""
        return np.array([self.position_of(n) for n in range(self.neg_no - 1, self.pos_no + 1)])


def _interval(span_mm: float, options: FanucOptions) -> float:
    if options.interval_mm is not None:
        return options.interval_mm
    return float(max(1, math.ceil(span_mm / options.max_points - 1e-9)))


def _quantized(correction_mm: np.ndarray, unit_mm: float) -> np.ndarray:
    return np.round(correction_mm / unit_mm).astype(int)


def _sides(m: AxisMap, interval: float) -> tuple[int, int]:
    """Intervals on the negative and the positive side of the reference position."""
    ref, lo, hi = m.reference_mm, m.positions_mm[0], m.positions_mm[-1]
    return (max(1, math.ceil((ref - lo) / interval - 1e-9)),
            max(1, math.ceil((hi - ref) / interval - 1e-9)))


def fanuc_axis(m: AxisMap, options: FanucOptions, first_point: int,
               first_neg_point: int | None) -> FanucAxis:
    ref = m.reference_mm
    interval = _interval(m.positions_mm[-1] - m.positions_mm[0], options)
    k_neg, k_pos = _sides(m, interval)
    if k_neg + k_pos > options.max_points:
        raise TableError(f"axis {m.axis}: {k_neg + k_pos} positions of {interval:g} mm, more "
                         f"than the {options.max_points} allowed: a larger interval_mm")
    ref_no = first_point + k_neg - 1
    numbers = np.arange(first_point - 1, ref_no + k_pos + 1)  # one before 3621: its start
    where = ref + (numbers - ref_no) * interval
    correction_fwd = -m.error_mm(where, 1)
    correction_rev = -m.error_mm(where, -1)
    unit = options.detection_unit_mm
    worst = 0
    for magnification in range(1, options.max_magnification + 1):
        step = unit * magnification
        fwd = np.diff(_quantized(correction_fwd, step))
        rev = np.diff(_quantized(correction_rev, step))
        worst = int(max(np.abs(fwd).max(), np.abs(rev).max() if options.bidirectional else 0))
        if worst <= options.value_limit:
            break
    else:
        raise TableError(f"axis {m.axis}: a change of {worst} units per {interval:g} mm "
                         f"exceeds ±{options.value_limit} even at magnification "
                         f"{options.max_magnification}: a smaller interval_mm")
    reversal = float(np.mean(m.error_mm(where[1:], -1) - m.error_mm(where[1:], 1)))
    return FanucAxis(
        axis=m.axis, reference_mm=ref, interval_mm=interval, magnification=magnification,
        unit_mm=step, ref_no=ref_no, neg_no=first_point, pos_no=ref_no + k_pos,
        values=tuple(int(v) for v in fwd),
        neg_dir_no=first_neg_point if options.bidirectional else None,
        neg_values=tuple(int(v) for v in rev) if options.bidirectional else (),
        # 3627 in detection units; where[k_neg] is the reference position
        ref_opposite=int(round(float(correction_rev[k_neg]) / unit))
        if options.bidirectional else 0,
        backlash=0 if options.bidirectional else int(round(reversal / unit)))


def _staircase(axis: FanucAxis, absolute_mm: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
    """The compensation between positions: that of the position below (see above)."""
    starts = axis.positions_mm()

    def at(x: np.ndarray) -> np.ndarray:
        k = np.clip(np.searchsorted(starts, np.asarray(x, float) + 1e-9, side="right") - 1,
                    0, len(starts) - 1)
        return absolute_mm[k]

    return at


def _applied(axis: FanucAxis) -> Applied:
    fwd = _staircase(axis, axis.absolute(axis.values) * axis.unit_mm)
    if axis.neg_values:
        rev_abs = (axis.absolute(axis.neg_values) * axis.unit_mm
                   + axis.ref_opposite * (axis.unit_mm / axis.magnification))
        rev = _staircase(axis, rev_abs)
    else:
        backlash_mm = axis.backlash * axis.unit_mm / axis.magnification
        rev = _staircase(axis, axis.absolute(axis.values) * axis.unit_mm - backlash_mm)

    def applied(x: np.ndarray, side: int) -> np.ndarray:
        return -(fwd(x) if side > 0 else rev(x))  # the error removed: minus the correction

    return applied


def _probes(axis: FanucAxis) -> tuple[float, ...]:
    """Each position, and just before it: the staircase's largest residual."""
    at = axis.positions_mm()
    return tuple(float(v) for v in np.concatenate([at, at - 1e-6]))


def fanuc_sheets(maps: Mapping[str, AxisMap], options: FanucOptions = FanucOptions(),
                 ) -> list[FanucAxis]:
    """Each axis's parameters and values: the positive-direction tables of the axes
    one after the other from ``first_point``, then their negative-direction tables."""
    counts = [sum(_sides(m, _interval(m.positions_mm[-1] - m.positions_mm[0], options)))
              for m in maps.values()]
    point, neg_point = options.first_point, options.first_point + sum(counts)
    out = []
    for m, count in zip(maps.values(), counts, strict=True):
        out.append(fanuc_axis(m, options, point, neg_point))
        point += count
        neg_point += count
    return out


def fanuc_tables(maps: Mapping[str, AxisMap], options: FanucOptions = FanucOptions(), *,
                 title: str = "") -> ControllerTables:
    sheets = fanuc_sheets(maps, options)
    axes = {s.axis: AxisTable(s.axis, maps[s.axis], _applied(s), probes_mm=_probes(s),
                              spacing_mm=s.interval_mm) for s in sheets}
    lines = [f"# {safe_text(title)}" if title else "# ogacq compensation",
             "# FANUC pitch error compensation (parameters 3620-3627; values are increments per",
             "# interval in the compensation unit, the correction = minus the error; absolute",
             "# compensation 0 at the reference position). Key in per axis:",
             f"# sign: {SIGN}"]
    for s in sheets:
        lines += ["", f"axis {s.axis}",
                  f"  3620 reference position number            = {s.ref_no}",
                  f"  3621 farthest negative position number    = {s.neg_no}",
                  f"  3622 farthest positive position number    = {s.pos_no}",
                  f"  3623 magnification                        = {s.magnification}",
                  f"  3624 interval                             = {s.interval_mm:g} mm "
                  f"({round(s.interval_mm / options.detection_unit_mm)} detection units of "
                  f"{options.detection_unit_mm:g} mm)",
                  f"  compensation unit                         = {s.unit_mm:g} mm",
                  f"  reference position                        = {s.reference_mm:g} mm "
                  "(machine coordinate of the reference return)"]
        if s.neg_dir_no is not None:
            lines += ["  3605#0 bidirectional pitch error compensation = 1",
                      f"  3626 farthest negative position number, negative direction = "
                      f"{s.neg_dir_no}",
                      f"  3627 absolute compensation at the reference position, approached "
                      f"opposite to the reference return (assumed +) = {s.ref_opposite} "
                      "detection units"]
        else:
            lines += [f"  1851 backlash compensating value          = {s.backlash} "
                      "detection units",
                      "  1852 backlash for rapid traverse (when 1800#4 is set): measure it at "
                      "rapid traverse; the value above is from positioning moves"]
        lines.append("  No.    section end (mm)   value" + ("   negative-direction No.  value"
                                                           if s.neg_values else ""))
        for k, n in enumerate(range(s.neg_no, s.pos_no + 1)):
            row = f"  {n:5d}  {s.position_of(n):14.3f}   {s.values[k]:+3d}"
            if s.neg_values and s.neg_dir_no is not None:
                row += f"   {s.neg_dir_no + k:22d}  {s.neg_values[k]:+3d}"
            lines.append(row)
    lines += ["", *figures_block(axes, "#"), *uncertainty_block(axes, "#")]
    name = "fanuc.txt" if options.bidirectional else "fanuc-backlash.txt"
    return ControllerTables(FORMAT, {name: "\n".join(lines) + "\n"}, axes)
