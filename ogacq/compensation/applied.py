"""ogacq's own compensation: the maps applied to every target it commands.

The Modbus drives ogacq drives (CiA 402, IAI, MR-JE-C, Kinco) hold no error
table, so ogacq corrects each target itself, as it applies the IAI software offset
table: for a joint to land at ``q`` approached from side ``a``, it commands
``AxisMap.corrected_target(q, a)`` (about ``q - e(q, a)``). The side is the
direction of the move to the target, as the plan moves: a joint that has not moved
yet has no side, and gets the mean of both.

What the readings record is where the joint was meant to be (the plan's target,
plus what the controller's rounding of the commanded target added): with the
maps right, the joint is there, and the model sees a machine without that error.
A corrected target beyond the travel (a target at its end, a lost motion to make
up) is held at the end: the controller refuses a move past its soft limits. The
joint then lands short of the target by what was held back, and the reading
records that too (its ``q`` is the target plus the difference).
"""

from __future__ import annotations

from collections.abc import Mapping

from ogacq.model.axis_map import AxisMap
from ogacq.model.parameters import AXES

Triple = tuple[float, float, float]


class TargetCorrection:
    """Corrects the targets of one run, move by move (it remembers each joint's last
    target and side)."""

    def __init__(self, maps: Mapping[str, AxisMap],
                 travel_mm: tuple[float, float] | None = None) -> None:
        self.maps = {a: maps[a] for a in AXES if a in maps}
        self.travel_mm = travel_mm  # (lowest, highest) target the controller takes
        self._last: list[float | None] = [None, None, None]
        self._side = [0, 0, 0]
        self._wanted: Triple | None = None  # the last corrected targets, before holding

    def command(self, q_mm: Triple) -> Triple:
        """The targets to command for the joints to land at ``q_mm``."""
        out = []
        for k, axis in enumerate(AXES):
            q = float(q_mm[k])
            last = self._last[k]
            if last is not None and abs(q - last) > 1e-9:
                self._side[k] = 1 if q > last else -1
            self._last[k] = q
            m = self.maps.get(axis)
            out.append(q if m is None else m.corrected_target(q, self._side[k]))
        self._wanted = (out[0], out[1], out[2])
        if self.travel_mm is not None:
            low, high = self.travel_mm
            out = [min(max(v, low), high) if axis in self.maps else v
                   for v, axis in zip(out, AXES, strict=True)]
        return (out[0], out[1], out[2])

    def forget(self) -> None:
        """The joints are no longer where the last targets put them (a stop, a loss of the
        drive, a new homing): the side of the next approach is unknown."""
        self._last = [None, None, None]
        self._side = [0, 0, 0]
        self._wanted = None

    def nominal(self, q_mm: Triple, resolved: Triple) -> Triple:
        """Where the joints were meant to be after the last ``command``: the target, plus
        what the controller's rounding (``resolved``: the targets it took) and a target
        held at the end of the travel moved."""
        wanted = self._wanted if self._wanted is not None else q_mm
        x, y, z = (round(q + (r - w), 9) for q, w, r in zip(q_mm, wanted, resolved, strict=True))
        return x, y, z
