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

A periodic correction (a screw's cyclic error: every term of its map repeats with the
screw's revolution) is one shape along the whole travel, and goes wrong as a whole:
its amplitude, its phase (the map shifted along q) or its pitch (the map stretched
about its reference, a phase that slips the farther from it). The test is asked, for
each of the three, how large an error of that kind it would pass at the same even
odds, and what that error leaves at the worst point of the travel
(:class:`PeriodSight`). When none leaves as much as the correction's own size, and
the test sees the correction directly over some stretch, the correction is shown
over the travel by its period: beyond the stretches seen its values rest on the
error repeating unchanged each revolution, which the sentence says, with what would
measure it there (an axis scale).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from statistics import NormalDist
from typing import Any

import numpy as np

from ogacq.identify.consistency import Verdict
from ogacq.identify.consistency import judge as test_of
from ogacq.identify.distributions import chi2_sf, f_sf
from ogacq.identify.fit import FitResult
from ogacq.model.axis_map import AxisMap
from ogacq.model.error_maps import JointHistory, terms_of
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
# points a period at which a periodic shape's largest value is taken: its largest
# missed by at most 1 - cos(pi / 20), 1.2 % (as the tables' own grid, error_maps)
POINTS_PER_PERIOD = 20
# A periodic correction is seen by its period only where the validation sees it directly
# over this many periods: a pitch wrong enough to alias (15.08 mm written for a 20 mm
# lead, the case the sight was made for) slips by half a period or more over them and
# fails there, where the period's test, linear in the error, would not see it far off
# (no source: a choice).
PERIODS_SEEN = 2.0


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
    period: PeriodSight | None = None  # a periodic correction's modes (the docstring)

    @property
    def seen_directly(self) -> tuple[bool, ...]:
        return tuple(limit <= self.correction_mm for limit in self.limits_mm)

    @property
    def seen(self) -> tuple[bool, ...]:
        """Per stretch: seen directly, or by the correction's period (seen directly over
        ``PERIODS_SEEN`` of its periods, and what its modes may be off by leaving less
        than its size there)."""
        direct = self.seen_directly
        period = self.period
        if period is None or self.longest_seen_mm() < PERIODS_SEEN * period.pitch_mm:
            return direct
        return tuple(d or v <= self.correction_mm
                     for d, v in zip(direct, period.bounds_mm, strict=True))

    @property
    def shown(self) -> bool:
        return all(self.seen)

    def longest_seen_mm(self) -> float:
        """The longest run of stretches seen directly, in mm of travel."""
        return max((length for _, _, length in self._runs(self.seen_directly)), default=0.0)

    @property
    def unseen_limit_mm(self) -> float:
        """The largest error the test would pass where it does not see the correction
        (directly, or by its period where that is taken)."""
        by_period = self.period.bounds_mm if self.period and self.seen != self.seen_directly \
            else (math.inf,) * len(self.limits_mm)
        return max((min(limit, leaves) for limit, leaves, seen
                    in zip(self.limits_mm, by_period, self.seen, strict=True) if not seen),
                   default=0.0)

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
        period = (self.period.merged(other.period) if self.period and other.period
                  else self.period or other.period)
        return AxisSight(self.axis, self.correction_mm, self.edges_mm,
                         _least(self.limits_mm, other.limits_mm),
                         min(self.noise_mm, other.noise_mm), period=period)

    def seen_where(self, directly: bool = False) -> str:
        """The stretches seen: "q from -20 to +0 mm"."""
        runs = self._runs(self.seen_directly if directly else self.seen)
        return ", ".join(f"q from {lo:+.0f} to {hi:+.0f} mm" for lo, hi, _ in runs)

    def _runs(self, flags: tuple[bool, ...]) -> list[list[float]]:
        """The stretches ``flags`` marks, joined where they touch: [from, to, length]."""
        runs: list[list[float]] = []
        spans = zip(self.edges_mm[:-1], self.edges_mm[1:], strict=True)
        for (lo, hi), seen in zip(spans, flags, strict=True):
            if not seen:
                continue
            if runs and math.isclose(runs[-1][1], lo):
                runs[-1][1] = hi
                runs[-1][2] += hi - lo
            else:
                runs.append([lo, hi, hi - lo])
        return runs

    def sentence(self) -> str:
        """What the validation shows of this correction, in words."""
        if self.by_scale:
            return self.by_scale
        size = self.correction_mm * UM_PER_MM
        noise = self.noise_mm * UM_PER_MM
        by_period = self.period is not None and self.seen != self.seen_directly
        if self.shown and by_period:
            assert self.period is not None
            return (f"the {self.axis} correction ({_two(size)} µm about its mean) is shown "
                    f"over the travel: directly over {self.seen_where(directly=True)}, "
                    f"elsewhere by its period ({self.period.pitch_mm:.4g} mm): "
                    f"{self.period.bound_words(noise)}. Beyond what it reads this holds "
                    "for an "
                    "error that repeats unchanged each screw revolution, which the gauges "
                    f"did not measure there; an axis scale along the {self.axis} actuator "
                    f"([axis_scale.{self.axis}] in the campaign file) would")
        if self.shown:
            return (f"the {self.axis} correction ({_two(size)} µm about its mean) is shown over "
                    "the travel: "
                    f"an error of its size anywhere would fail the validation's test "
                    f"(limit at most {_two(self.worst_mm * UM_PER_MM)} µm at its "
                    f"{noise:.2g} µm noise)")
        where = self.seen_where()
        unseen = self.unseen_limit_mm
        worst = unseen * UM_PER_MM
        times = (unseen / self.correction_mm) ** 2 if self.correction_mm > 0 else math.inf
        passed = (f"an error up to {_two(worst)} µm" if math.isfinite(worst)
                  else "an error of any size")
        more = (f"about {times:.{1 if times < 10 else 0}f} times the readings there"
                if math.isfinite(times)
                else "readings that see this joint there")
        return (f"the {self.axis} correction ({_two(size)} µm about its mean) is not shown: the "
                "validation "
                + (f"finds {self.period.off_words()} and " if self.period
                   and self.period.beyond_chance else "")
                + (f"sees an error of its size only over {where}"
                   + (" (by its period beyond what it reads)" if by_period else "")
                   if where else
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
                "limits_mm": _rounded(self.limits_mm),
                "noise_mm": self.noise_mm, "shown": self.shown,
                **({"by": "axis scale"} if self.by_scale else {}),
                **({"period": self.period.to_json()} if self.period else {})}


# The ways a periodic correction goes wrong as a whole, in the words of a sentence.
MODES = ("amplitude", "phase", "pitch")


@dataclass(frozen=True)
class PeriodSight:
    """How far one validation sees a periodic correction go wrong as a whole, per
    stretch of the travel (the :class:`AxisSight`'s): ``reach_mm``, the most that an
    error of any mode (``MODES``) its targeted test would pass at even odds leaves
    there; ``bounds_mm``, the larger of that and what each mode as found leaves there
    (a stretch is seen by the period where an error of the correction's size would be
    seen and none as large is found). ``found_mm``: each mode as found, by what it
    leaves at the travel's worst point; ``beyond_chance``: the modes found off beyond
    chance."""

    pitch_mm: float  # the correction's longest period
    reach_mm: tuple[float, ...]
    bounds_mm: tuple[float, ...]
    found_mm: tuple[float, float, float]
    beyond_chance: tuple[str, ...] = ()

    def merged(self, other: PeriodSight) -> PeriodSight:
        """Two validations: each stretch bounded by the tighter of the two, the modes as
        the one that bounds them best found them."""
        best = self if max(self.bounds_mm) <= max(other.bounds_mm) else other
        return replace(best, reach_mm=_least(self.reach_mm, other.reach_mm),
                       bounds_mm=_least(self.bounds_mm, other.bounds_mm))

    def bound_words(self, noise_um: float) -> str:
        said = (f"the validation would see an error of its {', '.join(MODES[:-1])} or "
                f"{MODES[-1]} that left its size there, and finds none (at most "
                f"{max(self.bounds_mm) * UM_PER_MM:.2g} µm, at its {noise_um:.2g} µm noise)")
        return said + (f"; {self.off_words()}, less than its size" if self.beyond_chance
                       else "")

    def off_words(self) -> str:
        found = dict(zip(MODES, self.found_mm, strict=True))
        return ", ".join(f"its {m} found off beyond chance (by {found[m] * UM_PER_MM:.2g} µm "
                         "at the travel's worst point)" for m in self.beyond_chance)

    def to_json(self) -> dict[str, Any]:
        return {"pitch_mm": round(self.pitch_mm, 6),
                "reach_mm": _rounded(self.reach_mm), "bounds_mm": _rounded(self.bounds_mm),
                "found_mm": {m: round(v, 7) for m, v in zip(MODES, self.found_mm,
                                                            strict=True)},
                "beyond_chance": list(self.beyond_chance)}


def _least(one: tuple[float, ...], other: tuple[float, ...]) -> tuple[float, ...]:
    return tuple(min(pair) for pair in zip(one, other, strict=True))


def _rounded(values: tuple[float, ...]) -> list[float | None]:
    return [round(v, 7) if math.isfinite(v) else None for v in values]


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

    def readings_of(a: int) -> Callable[[Shape], np.ndarray]:
        """What an error of joint ``a`` of a given shape does to every reading."""
        def readings(shape: Shape) -> np.ndarray:
            at_setting = shape(history.setting_q_mm[:, a], history.setting_side[:, a])
            return (shape(history.q_mm[:, a], history.side[:, a]) * s_r[:, a]
                    + at_setting[gauge] * s_s[:, a])
        return readings

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
        modes = periodic_modes(m)
        period = None if modes is None else modes.tested(
            readings_of(a), noncentrality, result.residuals, edges, verdict.level)
        out[axis] = AxisSight(axis, size, tuple(float(e) for e in edges), tuple(limits),
                              verdict.noise.sigma_mm, period=period)
    return out


Shape = Callable[[np.ndarray, np.ndarray], np.ndarray]  # e(q, side), mm


@dataclass(frozen=True)
class PeriodicModes:
    """A periodic map's ways of going wrong as a whole, each per unit of its error: its
    amplitude (the map itself about its mean, per unit of relative error), its phase
    (the map shifted along q, per mm) and its pitch (the map stretched about its
    reference, per unit of relative pitch error). Taken from the tabulated map, so any
    sum of periodic terms (a lead and its harmonics) goes wrong alike."""

    pitch_mm: float
    shapes: tuple[Shape, Shape, Shape]

    def tested(self, readings: Callable[[Shape], np.ndarray],
               noncentrality: Callable[[np.ndarray], float], residuals: np.ndarray,
               edges: np.ndarray, level: float) -> PeriodSight:
        """The three modes fitted together to a validation's ``residuals`` (the targeted
        test beside its lack of fit: a one-dof test sees a given error with far fewer
        readings than one spread over hundreds of dof). ``readings`` gives what a mode
        does to each reading, ``noncentrality`` the test's whitened, projected sum of
        squares of a vector of readings, whose cross products come by polarisation."""
        columns = [readings(shape) for shape in self.shapes]
        normal = np.array([[_inner(noncentrality, u, v) for v in columns] for u in columns])
        moment = np.array([_inner(noncentrality, u, residuals) for u in columns])
        # per stretch and mode, the mode's largest value there
        largest = np.array([[self._largest(shape, x0, x1, self.pitch_mm)
                             for shape in self.shapes]
                            for x0, x1 in zip(edges[:-1], edges[1:], strict=True)])
        stretches = len(edges) - 1
        try:
            covariance = np.linalg.inv(normal)
        except np.linalg.LinAlgError:
            never = (math.inf,) * stretches
            return PeriodSight(self.pitch_mm, never, never, (0.0, 0.0, 0.0))
        std = np.sqrt(np.maximum(np.diag(covariance), 0.0))
        found = covariance @ moment
        # even odds, and the bound, for a two-sided test at ``level``; "beyond chance"
        # at it shared by the three modes (Bonferroni)
        z = NormalDist().inv_cdf(1 - level / 2)
        z_off = NormalDist().inv_cdf(1 - level / 6)
        reach = (z * std * largest).max(axis=1)
        bounds = (np.maximum(np.abs(found), z * std) * largest).max(axis=1)
        worst = np.abs(found) * largest.max(axis=0)
        off = tuple(m for m, c, sd in zip(MODES, found, std, strict=True)
                    if abs(c) > z_off * sd)
        return PeriodSight(self.pitch_mm, tuple(float(v) for v in reach),
                           tuple(float(v) for v in bounds),
                           (float(worst[0]), float(worst[1]), float(worst[2])), off)

    @staticmethod
    def _largest(shape: Shape, lo: float, hi: float, pitch_mm: float) -> float:
        n = max(2, math.ceil(POINTS_PER_PERIOD * (hi - lo) / pitch_mm) + 1)
        grid = np.linspace(lo, hi, n)
        return max(float(np.max(np.abs(shape(grid, np.full(n, d))))) for d in (1, -1))


def _inner(norm: Callable[[np.ndarray], float], u: np.ndarray, v: np.ndarray) -> float:
    return (norm(u + v) - norm(u) - norm(v)) / 2


def periodic_modes(m: AxisMap) -> PeriodicModes | None:
    """``m``'s modes when every term it was made from is periodic (None otherwise: a
    smooth map's values elsewhere rest on nothing it was seen over)."""
    terms = terms_of(m)
    if not terms or not all(t.kind.periodic for t in terms):
        return None
    pitches = [float(t.shape["pitch_mm"]) for t in terms]
    reference = terms[0].reference_mm
    step = min(pitches) / 40  # half the table's step (``Cyclic.table_step_mm``)
    mean = _mean(m)

    def amplitude(q: np.ndarray, side: np.ndarray) -> np.ndarray:
        return m.error_mm(q, side) - mean

    def shift(q: np.ndarray, side: np.ndarray) -> np.ndarray:
        return (m.error_mm(q + step, side) - m.error_mm(q - step, side)) / (2 * step)

    def stretch(q: np.ndarray, side: np.ndarray) -> np.ndarray:
        return shift(q, side) * (q - reference)

    return PeriodicModes(max(pitches), (amplitude, shift, stretch))


def _within(q: np.ndarray, lo: float, hi: float) -> np.ndarray:
    return ((q >= lo) & (q < hi)).astype(float)


def _two(value: float) -> str:
    """Two significant figures without an exponent: 95, 100, 3.8."""
    return f"{float(f'{value:.2g}'):g}"


def largest_correction(m: AxisMap, lo: float, hi: float) -> float:
    """The correction's largest value from ``lo`` to ``hi``, either direction, less its
    mean over the map's range (a constant is the joint offset's): at the map's own points
    there and the two ends, where a map linear between its points is largest. (At 41
    points over the travel, 4 mm apart, a 4 mm lead's map of 4 um read as 1 um: every
    point at about the same phase, and the validation held to showing 1 um.)"""
    q = np.asarray(m.positions_mm, dtype=float)
    grid = np.concatenate([[lo, hi], q[(q > lo) & (q < hi)]])
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
