"""Where along each axis a validation would see its correction go wrong.

A validation is "validated" when its fit of the joint offsets is within the gauge
noise. That says something of a map only where an error of the map's size would have
failed that test. The gauges see a joint's error through the kinematics: on the
Orthoglide the papers' gauges of a joint's own leg read across its line (a
sensitivity of 0.03-0.13 along the travel, zero where the gauges were set), and the
other legs' gauges read along it (0.3-0.7) but only over the 16 mm or so that the
joint moves while those legs are driven. A validation's readings of a 4 µm map are
then 98 % of them in that stretch: there it sees the map, elsewhere an error forty
times larger would pass, and a map whose pitch or shape is wrong beyond the stretch
(a 15 mm pitch found for a 20 mm lead fits that stretch alike) is "validated".

So the validation's test is asked, for every stretch of each corrected axis's range,
whether it would reject a joint error there of the correction's own shape and size:
its noncentrality, what the error adds to the test's statistic (the verdict's own
test, ``consistency.judge``, given the error's readings as the residual: the same
whitening, the gauge zeros and the fitted parameters projected out), set against
what takes the statistic's mean to its critical value at the verdict's level (about
even odds of a rejection: the noncentral chi-square's mean is its dof plus the
noncentrality; Johnson, Kotz and Balakrishnan, *Continuous Univariate
Distributions* 2, 2nd ed., 1995, ch. 29). The limit of a stretch is the size of the
correction's shape there at which the test reaches it. The travel is cut into
``STRETCHES`` equal stretches, each about as long as the stretch the other legs move
a joint through (160 mm of travel: 18 mm), so that what they see is one stretch and
not a share of every one.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ogacq.identify.consistency import Verdict
from ogacq.identify.consistency import judge as test_of
from ogacq.identify.distributions import chi2_sf, f_sf
from ogacq.identify.fit import FitResult
from ogacq.model.axis_map import AxisMap
from ogacq.model.error_maps import JointHistory
from ogacq.model.joint_sensitivity import joint_sensitivity
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import AXES
from ogacq.model.units import UM_PER_MM

# No source: a choice, the travel of the papers' prototype (-100 to +60 mm) cut into
# stretches about as long as the 16 mm the other legs move a joint through.
STRETCHES = 9
# A stretch where the correction is below this share of its largest value corrects
# next to nothing there: nothing of it to show (no source: a choice).
NEGLIGIBLE = 0.01
GRID = 41  # points per stretch at which the correction's size there is taken


@dataclass(frozen=True)
class AxisSight:
    """How far one validation sees an axis's correction: per stretch of the axis's
    travel (``edges_mm``), the smallest error of the correction's shape there that its
    test would reject at even odds (inf: none it can see; 0: nothing to show there)."""

    axis: str
    correction_mm: float  # the correction's largest value over the range
    edges_mm: tuple[float, ...]
    limits_mm: tuple[float, ...]
    noise_mm: float  # the noise of the test the limits are of
    # seen by the axis's scale (ogacq.calibration.scale_check): what it found, in words
    by_scale: str = ""

    @property
    def seen(self) -> tuple[bool, ...]:
        return tuple(limit <= self.correction_mm for limit in self.limits_mm)

    @property
    def shown(self) -> bool:
        return all(self.seen)

    @property
    def worst_mm(self) -> float:
        return max(self.limits_mm, default=0.0)

    def merged(self, other: AxisSight) -> AxisSight:
        """Two validations of the same correction: a stretch is seen when either sees
        it (the limits are on the same edges: the joint's travel)."""
        scale = self if self.by_scale else other if other.by_scale else None
        if scale is not None:  # the scale's test judges the axis over its whole travel
            return scale
        if other.edges_mm != self.edges_mm:
            return self if self.worst_mm <= other.worst_mm else other
        return AxisSight(self.axis, self.correction_mm, self.edges_mm,
                         tuple(min(a, b) for a, b in zip(self.limits_mm, other.limits_mm,
                                                         strict=True)),
                         min(self.noise_mm, other.noise_mm))

    def seen_where(self) -> str:
        """The stretches seen, joined where they touch: "q from -20 to +0 mm"."""
        runs: list[list[float]] = []
        spans = zip(self.edges_mm[:-1], self.edges_mm[1:], strict=True)
        for (lo, hi), seen in zip(spans, self.seen, strict=True):
            if not seen:
                continue
            if runs and math.isclose(runs[-1][1], lo):
                runs[-1][1] = hi
            else:
                runs.append([lo, hi])
        return ", ".join(f"q from {lo:+.0f} to {hi:+.0f} mm" for lo, hi in runs)

    def sentence(self) -> str:
        """What the validation shows of this correction, in words."""
        if self.by_scale:
            return self.by_scale
        size = self.correction_mm * UM_PER_MM
        noise = self.noise_mm * UM_PER_MM
        if self.shown:
            return (f"the {self.axis} correction ({size:.2g} µm about its mean) is shown over "
                    "the travel: "
                    f"an error of its size anywhere would fail the validation's test "
                    f"(limit at most {self.worst_mm * UM_PER_MM:.2g} µm at its "
                    f"{noise:.2g} µm noise)")
        where = self.seen_where()
        worst = self.worst_mm * UM_PER_MM
        times = (self.worst_mm / self.correction_mm) ** 2 if self.correction_mm > 0 \
            else math.inf
        passed = (f"an error up to {worst:.2g} µm" if math.isfinite(worst)
                  else "an error of any size")
        more = (f"about {times:.0f} times the readings there" if math.isfinite(times)
                else "readings that see this joint there")
        return (f"the {self.axis} correction ({size:.2g} µm about its mean) is not shown: the "
                "validation "
                + (f"sees an error of its size only over {where}" if where else
                   "sees an error of its size nowhere along the axis")
                + f"; elsewhere {passed} would pass its test (at its {noise:.2g} µm noise: "
                "its gauges see this joint there through a small sensitivity). What would "
                f"show it: {more}, or an axis scale along the {self.axis} actuator "
                f"([axis_scale.{self.axis}] in the campaign file; --axis-scales on the "
                "simulator): calibrate then validates the map by ISO 230-2's positioning "
                "test over the whole travel (`ogacq positioning` runs it alone)")

    def to_json(self) -> dict[str, Any]:
        return {"axis": self.axis, "correction_mm": round(self.correction_mm, 7),
                "edges_mm": [round(e, 4) for e in self.edges_mm],
                "limits_mm": [round(v, 7) if math.isfinite(v) else None
                              for v in self.limits_mm],
                "noise_mm": self.noise_mm, "shown": self.shown,
                **({"by": "axis scale"} if self.by_scale else {})}


def shown(sights: dict[str, AxisSight]) -> bool:
    return all(s.shown for s in sights.values())


def merged(one: dict[str, AxisSight], other: dict[str, AxisSight]) -> dict[str, AxisSight]:
    return {a: one[a].merged(other[a]) if a in one and a in other else one.get(a) or other[a]
            for a in AXES if a in one or a in other}


def sights(maps: dict[str, AxisMap], result: FitResult, verdict: Verdict,
           machine: MachineSpec) -> dict[str, AxisSight]:
    """Per corrected axis, how far the validation fitted by ``result`` (whose test is
    ``verdict``) sees the correction ``maps`` hold there."""
    if not verdict.judged or not maps:
        return {}
    obs = result.observations
    history = JointHistory.of(obs.layout)
    s_r, s_s = joint_sensitivity(result.theta, obs.layout, machine).along()
    needed = _noncentrality_needed(verdict)
    gauge = obs.layout.gauge

    def noncentrality(signal: np.ndarray) -> float:
        v = test_of(obs, signal, result.jacobian, result.identifiability.rank,
                    verdict.noise, verdict.level)
        return v.statistic * v.dof if v.test == "lack-of-fit F" else v.statistic

    out = {}
    for axis, m in maps.items():
        a = AXES.index(axis)
        q, q_set = history.q_mm[:, a], history.setting_q_mm[:, a]
        # about its mean, as its size is taken: the constant is the joint offset's
        e_r = m.error_mm(q, history.side[:, a]) - _mean(m)
        e_s = m.error_mm(q_set, history.setting_side[:, a]) - _mean(m)
        # the joint's travel, the same stretches for every validation of the correction
        lo, hi = machine.rho_min_mm, machine.rho_max_mm
        edges = np.linspace(lo, hi, STRETCHES + 1)
        size = largest_correction(m, lo, hi)
        limits = []
        for k, (x0, x1) in enumerate(zip(edges[:-1], edges[1:], strict=True)):
            # the first and last stretches take in what lies beyond the travel's ends
            bounds = (-math.inf if k == 0 else x0, math.inf if k == STRETCHES - 1 else x1)
            inside_r, inside_s = _within(q, *bounds), _within(q_set, *bounds)
            there = largest_correction(m, float(x0), float(x1))
            if there <= NEGLIGIBLE * size:
                limits.append(0.0)
                continue
            signal = (e_r * inside_r * s_r[:, a] + (e_s * inside_s)[gauge] * s_s[:, a]) / there
            lam = noncentrality(signal)  # of a unit error of the correction's shape there
            limits.append(math.sqrt(needed / lam) if lam > 0 else math.inf)
        out[axis] = AxisSight(axis, size, tuple(float(e) for e in edges), tuple(limits),
                              verdict.noise.sigma_mm)
    return out


def _within(q: np.ndarray, lo: float, hi: float) -> np.ndarray:
    return ((q >= lo) & (q < hi)).astype(float)


def largest_correction(m: AxisMap, lo: float, hi: float) -> float:
    """The correction's largest value from ``lo`` to ``hi``, either direction, less its
    mean over the map's range (a constant is the joint offset's)."""
    grid = np.linspace(lo, hi, GRID)
    return float(max(np.max(np.abs(m.error_mm(grid, d) - _mean(m))) for d in (1, -1)))


def _mean(m: AxisMap) -> float:
    return float(np.mean(np.concatenate([m.forward_mm, m.reverse_mm])))


def _noncentrality_needed(verdict: Verdict) -> float:
    """The noncentrality that takes the test statistic's mean to its critical value at
    the verdict's level (halved where a worst cell is tested beside: the verdict's p is
    the smaller of the two, doubled)."""
    level = verdict.level / 2 if verdict.worst_cell is not None else verdict.level
    dof = verdict.dof
    if verdict.test == "lack-of-fit F" and verdict.noise_dof is not None:
        denominator = verdict.noise_dof
        critical = _quantile(lambda f: float(f_sf(dof, denominator, f)), level)
        return dof * (critical - 1.0)
    if verdict.test == "lack-of-fit F":  # the denominator known: chi-square, per dof
        return _quantile(lambda x: float(chi2_sf(dof, x * dof)), level) * dof - dof
    return _quantile(lambda x: float(chi2_sf(dof, x)), level) - dof


def _quantile(survival: Callable[[float], float], level: float) -> float:
    """The x where a decreasing ``survival`` falls to ``level``, by bisection."""
    lo, hi = 0.0, 1.0
    while survival(hi) > level:
        lo, hi = hi, 2.0 * hi
    for _ in range(60):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if survival(mid) > level else (lo, mid)
    return (lo + hi) / 2
