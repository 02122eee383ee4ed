"""calibrate's validation of a written map through the axis's scale (ISO 230-2).

The legs' gauges see a joint's error along its line over the 16 mm or so it moves
while the other legs are driven (``ogacq.calibration.sight``): no validation by them
shows a screw map over the whole travel. A scale along the actuator does: the
positioning test (``ogacq.protocol.positioning``) before the write and after it gives
the deviation at targets over the whole travel, sampled at every lead's phases.

After the write, at each target and direction, the mean deviation must lie within its
tolerance: the map's own expanded uncertainty there (U, k = 2, the table's) combined
with twice the standard uncertainty of the measured deviation (``PositioningResult.u_mm``: the
runs' scatter pooled over every target over the square root of the runs, and the
scale's display step). A map is known about
its reference position (its u is nought there: the gauges are set at it), and the
scale reads up to a constant: so the deviations are taken from the one the test
finds at the map's reference (interpolated between its targets), whose own
uncertainty the tolerance carries too. The deviations are taken less what the
drive's rounding of each corrected target moved the joint (``TargetCorrection``'s
nominal landing): what the map leaves, not the drive's step, which the figures state
beside them (``ogacq.calibration.drive_step``). The map is shown on that axis when
its deviations are within tolerance at ``WITHIN_SHARE`` of the targets (95 %: a
coverage of k = 2) and its E and A (ISO 230-2) are not worse than before beyond
``SIGMAS`` of what the two tests' means can differ by chance; worse when they are.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ogacq.calibration.sight import STRETCHES, AxisSight
from ogacq.model.axis_map import AxisMap
from ogacq.model.machine import MachineSpec
from ogacq.model.units import UM_PER_MM
from ogacq.protocol.positioning import PositioningResult

WITHIN_SHARE = 0.95  # of the targets and directions: a k = 2 coverage's
SIGMAS = 3.0  # as the validation's own margin (ogacq.calibration.validate.SIGMAS)


@dataclass(frozen=True)
class ScaleCheck:
    """What the axis's scale found of the written map."""

    axis: str
    targets_mm: tuple[float, ...]
    deviation_mm: tuple[float, ...]  # after, per target: the larger of the two directions
    tolerance_mm: tuple[float, ...]  # per target
    before: dict[str, Any]  # ISO 230-2 figures (JSON) before the write, by the scale
    after: dict[str, Any]
    margin_mm: float  # how far E or A may grow by chance
    runs: int

    @property
    def within(self) -> int:
        return sum(abs(d) <= t for d, t in zip(self.deviation_mm, self.tolerance_mm,
                                                strict=True))

    @property
    def worse(self) -> str:
        """Why the axis is worse than before by its scale ("" when it is not)."""
        grew = [f"{name} grew from {self.before[f'{name}_mm'] * UM_PER_MM:.1f} to "
                f"{self.after[f'{name}_mm'] * UM_PER_MM:.1f} µm"
                for name in ("E", "A")
                if self.after[f"{name}_mm"] > self.before[f"{name}_mm"] + self.margin_mm]
        return f"axis {self.axis}, by its scale: {' and '.join(grew)} (ISO 230-2)" if grew \
            else ""

    @property
    def shown(self) -> bool:
        return not self.worse and self.within >= WITHIN_SHARE * len(self.targets_mm)

    def sentence(self) -> str:
        n = len(self.targets_mm)
        figures = (f"E {self.before['E_mm'] * UM_PER_MM:.2f} -> "
                   f"{self.after['E_mm'] * UM_PER_MM:.2f} µm, A "
                   f"{self.before['A_mm'] * UM_PER_MM:.2f} -> "
                   f"{self.after['A_mm'] * UM_PER_MM:.2f} µm")
        where = (f"by its axis scale along the whole travel ({n} targets from "
                 f"{min(self.targets_mm):+g} to {max(self.targets_mm):+g} mm, {self.runs} "
                 f"runs each way, ISO 230-2)")
        if self.shown:
            return (f"the {self.axis} correction is shown {where}: its deviations after lie "
                    f"within the map's U (k = 2) and the test's own at {self.within} of {n} "
                    f"targets; {figures}")
        if self.worse:
            return f"the {self.axis} correction is worse {where}: {self.worse}"
        return (f"the {self.axis} correction is not shown {where}: its deviations after lie "
                f"within the map's U (k = 2) and the test's own at {self.within} of {n} "
                f"targets only (at least {WITHIN_SHARE:.0%} wanted; largest "
                f"{max(map(abs, self.deviation_mm)) * UM_PER_MM:.2f} µm); {figures}")

    def sight(self, correction_mm: float, machine: MachineSpec) -> AxisSight:
        """The check as the validation's sight of the axis: per stretch of the travel, the
        largest tolerance of its targets there (an error beyond it would show), inf
        everywhere when the check does not show the map (and where no target lies).
        One target beyond its tolerance in a stretch leaves it seen: a coverage of k = 2
        puts one in twenty there by chance (``WITHIN_SHARE``)."""
        edges = np.linspace(machine.rho_min_mm, machine.rho_max_mm, STRETCHES + 1)
        t = np.asarray(self.targets_mm)
        limits = []
        for k, (lo, hi) in enumerate(zip(edges[:-1], edges[1:], strict=True)):
            inside = (t >= lo) & ((t < hi) | (k == STRETCHES - 1))
            limits.append(float(np.max(np.asarray(self.tolerance_mm)[inside]))
                          if inside.any() and self.shown else math.inf)
        return AxisSight(self.axis, correction_mm, tuple(float(e) for e in edges),
                         tuple(limits), float(np.median(self.tolerance_mm)) / 2.0,
                         by_scale=self.sentence())

    def to_json(self) -> dict[str, Any]:
        return {"axis": self.axis, "targets_mm": list(self.targets_mm),
                "deviation_after_mm": [round(d, 7) for d in self.deviation_mm],
                "tolerance_mm": [round(t, 7) for t in self.tolerance_mm],
                "within": self.within, "shown": self.shown, "worse": self.worse or None,
                "iso230_2": {"before": self.before, "after": self.after},
                "margin_mm": round(self.margin_mm, 7), "runs": self.runs}


def scale_check(before: PositioningResult, after: PositioningResult,
                axis_map: AxisMap) -> ScaleCheck:
    """The written ``axis_map`` judged by its axis's positioning tests before and after
    the write (both net of the drive's rounding)."""
    targets = after.targets_mm
    u_map = np.maximum(np.interp(targets, axis_map.positions_mm, axis_map.u_forward_mm),
                       np.interp(targets, axis_map.positions_mm, axis_map.u_reverse_mm))
    u_mean = after.u_mm
    # the deviation and its u from the reference's: two measured means
    tolerance = 2.0 * np.sqrt(u_map**2 + 2.0 * u_mean**2)
    at_reference = float(np.interp(axis_map.reference_mm, targets, after.mean_mm))
    up, down = after.up_mm - at_reference, after.down_mm - at_reference
    worst = np.where(np.abs(up) >= np.abs(down), up, down)
    # E and A of two tests differ by chance by a few of their means' u, each side
    margin = SIGMAS * 2.0 * math.hypot(u_mean, before.u_mm)
    return ScaleCheck(after.axis, tuple(float(t) for t in targets),
                      tuple(float(d) for d in worst), tuple(float(t) for t in tolerance),
                      before.figures.to_json(), after.figures.to_json(), margin, after.runs)

