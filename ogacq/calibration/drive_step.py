"""The drive's step in every figure a calibration states.

A Modbus drive takes its target in whole counts (the profile's ``codec.counts_per_mm``:
the CiA 402 position user unit, the IAI 0.01 mm register, ogacq_drivers/axes/profiles):
ogacq corrects a target ``q`` to ``q - e(q)`` and the drive goes to that rounded to a
count. The joint then lands within half a count of ``q`` at best, whatever the map.

The validation records where the drive was sent (the rounded target: the runner's
``TargetCorrection.nominal``), which is right for the model (the joint was there)
but hides the rounding from the figures it fits: an axis whose map corrects 4 um on
a drive of 10 um a count reads as corrected while each target is off by up to 5 um.
So each "as left" figure is stated beside its bound with the drive's step: the
rounding is deterministic per target (systematic in ISO 230-2:2014's sense), a range
of up to one count over the targets, which the systematic figures E and M, the
accuracy A and the reversal B can each carry in full; R (a scatter) does not.
A map whose corrections are all within a count is finer than the drive can step:
said so, with what the rounding leaves.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ogacq_drivers.axes.profile import load_profile
from ogacq.model.axis_map import AxisMap
from ogacq.model.units import UM_PER_MM

# ISO 230-2:2014 figures a per-target systematic rounding adds to (section 2: A, B, E, M
# are built from the mean deviations at each target; R from their scatter).
SYSTEMATIC = ("A", "B", "E", "M")


def drive_step_mm(profile: str) -> float:
    """The position step of the drives the profile names (1 / counts per mm)."""
    return 1.0 / load_profile(profile).codec.counts_per_mm


def with_drive_step(figures: Mapping[str, Mapping[str, Any]], step_mm: float,
                    ) -> dict[str, dict[str, Any]]:
    """Each axis's figures with the drive's step and the bound it sets on what is left:
    ``X_with_step_mm`` = X + one count, for the systematic figures."""
    out = {}
    for axis, fig in figures.items():
        bounded = dict(fig)
        bounded["drive_step_mm"] = step_mm
        for name in SYSTEMATIC:
            if f"{name}_mm" in fig:
                bounded[f"{name}_with_step_mm"] = float(fig[f"{name}_mm"]) + step_mm
        out[axis] = bounded
    return out


def finer_than_drive(maps: Mapping[str, AxisMap], step_mm: float) -> list[str]:
    """A sentence for each map whose corrections stay within one drive step."""
    out = []
    for axis, m in maps.items():
        largest = max(abs(v) for v in (*m.forward_mm, *m.reverse_mm))
        if largest < step_mm:
            out.append(f"the {axis} map corrects at most {largest * UM_PER_MM:.1f} µm, finer "
                       f"than the drive steps ({step_mm * UM_PER_MM:g} µm a count): each "
                       "corrected target is rounded to a whole count, which leaves up to "
                       f"{step_mm / 2 * UM_PER_MM:g} µm at a target")
    return out


def predicted_with_step(step_mm: float) -> str:
    """What the predicted figures after leave out: the drive's count at each target."""
    return (f"the figures after are the maps'; each target is a whole count of the drive "
            f"({step_mm * UM_PER_MM:g} µm), which adds up to one count to A, B, E and M at "
            "the commanded targets")
