"""Did the axes keep their position reference through a loss of the drive?

After a reconnect, an alarm, a power cycle or a stop whose aftermath is unknown,
a position the drive reports is only worth what its reference is. An
incremental encoder switched off and on counts from wherever the axis stands;
the same numbers then mean another place, and every later set-point goes
somewhere else. So the answer is asked of the drive itself, axis by axis:

1. its own homing state, where the profile has one (``flags.homed``: IAI DSS1
   bit 4 HEND, "home return completed" [ME0162]); where it has none (CiA 402
   defines no such bit outside homing mode: statusword bit 12 is "homing
   attained" in mode 6 only [CiA 402-2]), the drive cannot say: after any loss
   (an alarm, a lost link; switched off and on between two polls it reads the
   same) the caller forgets the homing, and the reference counts as lost;
2. its position within the machine's soft limits and their margin;
3. its position where it can have got to since it was last seen: on the way
   from the last position reached to the last target commanded (a stop may
   have left it anywhere between).

Any "no" means the reference is not vouched for: the caller homes again before
any set-point, or stops.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

from ogacq_drivers.axes.controller import AxisController


@dataclass(frozen=True)
class Path:
    """Where an axis may be: from the last position reached towards the last target."""

    start_mm: float
    end_mm: float

    def holds(self, q_mm: float, slack_mm: float) -> bool:
        low, high = sorted((self.start_mm, self.end_mm))
        return low - slack_mm <= q_mm <= high + slack_mm


@dataclass(frozen=True)
class AxisReference:
    """One axis's answer: kept or not, and why not."""

    axis: str
    position_mm: float
    homed: bool  # the drive's homing state (or this client's, where the drive has none)
    reasons: tuple[str, ...]  # empty: the reference is kept

    @property
    def kept(self) -> bool:
        return not self.reasons

    def describe(self) -> str:
        """``x at +67.770 mm: reason, reason`` (one line)."""
        return f"{self.axis} at {self.position_mm:+.3f} mm: {', '.join(self.reasons)}"

    def as_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"position_mm": round(self.position_mm, 6), "homed": self.homed}
        if self.reasons:
            out["reasons"] = list(self.reasons)
        return out


def assess_reference(controller: AxisController, paths: Mapping[str, Path] | None = None,
                     axes: Iterable[str] | None = None) -> dict[str, AxisReference]:
    """Each axis's reference as the drive shows it now (reads only, nothing written)."""
    low, high = controller.soft_limits_mm
    margin = controller.profile.limits.margin_mm
    slack = controller.position_tolerance_mm()
    out: dict[str, AxisReference] = {}
    statuses = controller.read_status(axes)
    for axis, status in statuses.items():
        q = status.position_mm
        reasons: list[str] = []
        if not status.homed:
            reasons.append("the drive reports it is not homed" if controller.reports_reference
                           else "the drive does not report whether it is homed, and was lost")
        if not low - margin <= q <= high + margin:
            reasons.append(f"outside the soft limits [{low:g}, {high:g}] mm")
        path = (paths or {}).get(axis)
        if path is not None and not path.holds(q, slack):
            reasons.append(f"not on its way from {path.start_mm:+.3f} to {path.end_mm:+.3f} mm")
        out[axis] = AxisReference(axis, q, status.homed, tuple(reasons))
    return out
