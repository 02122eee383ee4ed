"""Search the residuals for errors along each axis and in time that the effect
library lacks (``model/families/``), after the library search.

Where a campaign reads a joint at enough positions, every family of the registry is
tried on that axis beside the current model, at the shapes its module declares
(``MapFamily.search``). The cyclic lead-screw error is found by a periodogram: the
least-squares spectrum of N. R. Lomb (Astrophys. Space Sci. 39, 1976) and J. D.
Scargle (ApJ 263, 1982), with the joint's sensitivity and the model's directions
taken out, on a grid five times finer than the resolution 1 / span (J. T.
VanderPlas, ApJS 236, 2018, 7.1), over the band the positions resolve
(``pitch_band_mm``), summed over binned positions (``mapbins.py``), its peak refined
on the exact columns. A best pitch at the band's edge is not resolved (the true one
may lie beyond it): said so, with no std, and not added.

Each family's best shape is tested against the current model by the nested test
(``nested.py``), its p multiplied by the shapes tried and the families tried
(Bonferroni). A family is added when it passes, pays for its parameters by the BIC
(shape parameters counted) and has a plausible size; the best by the BIC first,
then the search goes on. The level is the verdict's, ten times stricter when the
library's model is within the noise: a search run on every campaign must not raise
the calibrated verdict's false alarms (``bench/verdict_calibration.py --maps``)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from functools import partial
from typing import Any

import numpy as np

from ogacq.diagnose.arrays import median, sorted_distinct
from ogacq.diagnose.batchfit import Problem
from ogacq.diagnose.mapbins import BINS_PER_PITCH, PositionSums, alias_pitch_mm, phasors
from ogacq.diagnose.mapspace import Gain, MapSpace
from ogacq.diagnose.nested import bic_change, nested_tests
from ogacq.identify.consistency import LEVEL
from ogacq.identify.noise import GaugeNoise
from ogacq.identify.search_rules import (
    OVERSAMPLE,
    SHORTEST_LEAD_MM,
    SWAP_CHI2,
    local_maxima,
)
from ogacq.model.error_maps import MapTerm, ShapeSpread
from ogacq.model.families import FAMILIES, SearchedAxis, ShapeGrid
from ogacq.model.gauges import AXES
from ogacq.model.measurement import ReadingsLayout
from ogacq.model.units import UM_PER_MM

# A joint read at fewer positions of its own travel is not searched for maps: a
# cyclic error needs more than two readings per period over several periods, a
# smooth map more positions than its spline has functions. No source: the smallest
# record on which these families are determined at all, with a margin.
MIN_POSITIONS = 10
MIN_PERIODS = 3.0  # over the span: a longer period is the smooth map's
SAMPLES_PER_PERIOD = 2.5  # distinct positions per period: above Nyquist's 2
# Shapes of q alone whose BIC on binned positions lies within this many knots' price
# (log n each) of the best are weighed again exactly: ten times the binning's largest
# error seen (no source: bench/bench_mapsearch_scale.py's dense scan).
SPLINE_MARGIN_KNOTS = 2
MAX_TERMS = 4  # map terms added at most
STRICTER_WHEN_CONSISTENT = 10.0
CHUNK = 64  # trial frequencies per batch
RIVALS = "pitch unresolved: "  # how a pitch between rival peaks is said (_rival_pitch)


@dataclass(frozen=True)
class AxisCoverage:
    """How a campaign read one joint: its own leg's positions, their spacing, the
    joint's whole range over all readings, and whether it was read from both sides."""

    axis: int
    positions: int
    from_mm: float
    to_mm: float
    step_mm: float
    both_sides: bool
    shortest_travel_mm: float  # after a reversal (inf: never reversed)
    # the display step, when its rounding dominates the gauge's noise (else None): the
    # rounding then follows the signal along q and would pass for a map
    display_limited_mm: float | None = None
    # the periods its positions sample, when a design states them (irregular positions
    # resolve periods far below their median spacing: ogacq.protocol.scan_design)
    designed_band_mm: tuple[float, float] | None = None
    # the shortest period the positions alias to a constant (mapbins.alias_pitch_mm):
    # the step of uniform positions, less for irregular ones (None: the step)
    alias_mm: float | None = None

    @property
    def dense(self) -> bool:
        return self.positions >= MIN_POSITIONS

    @property
    def searchable(self) -> bool:
        return self.dense and self.display_limited_mm is None

    @property
    def span_mm(self) -> float:
        return self.to_mm - self.from_mm

    @property
    def pitch_band_mm(self) -> tuple[float, float]:
        """The cyclic pitches these positions resolve: the band their design states,
        else 2.5 times the shortest period they alias (uniform positions: 2.5 a period;
        irregular ones, as ISO 230-2 places its targets, resolve shorter pitches than
        their mean step); never shorter than a screw's lead, to three periods over the
        span."""
        longest = self.span_mm / MIN_PERIODS
        if self.designed_band_mm is not None:
            return (max(self.designed_band_mm[0], SHORTEST_LEAD_MM),
                    min(self.designed_band_mm[1], longest))
        alias = self.step_mm if self.alias_mm is None else self.alias_mm
        return max(SAMPLES_PER_PERIOD * alias, SHORTEST_LEAD_MM), longest

    def describe(self) -> str:
        name = AXES[self.axis]
        if self.dense and self.display_limited_mm is not None:
            return (f"{name} axis read at {self.positions} positions, but the display's "
                    f"{self.display_limited_mm * UM_PER_MM:g} µm step dominates the gauge noise: "
                    "repeats round alike and the rounding follows the readings along q, "
                    "so it would pass for a map; not searched (a finer indicator would tell)")
        if self.dense:
            lo, hi = self.pitch_band_mm
            band = (f"; cyclic pitches resolved from {lo:.3g} to {hi:.3g} mm" if lo < hi
                    else "; no cyclic pitch resolved")
            return (f"{name} axis read at {self.positions} positions, {self.from_mm:+g} to "
                    f"{self.to_mm:+g} mm, every {self.step_mm:.3g} mm"
                    + (", from both sides" if self.both_sides else "") + band)
        return (f"{name} axis read at {self.positions} positions of its travel only: too few "
                f"for a map along q (at least {MIN_POSITIONS}; a scan shows one)")


def coverage(layout: ReadingsLayout, travel_mm: np.ndarray,
             display_limited_mm: float | None = None) -> tuple[AxisCoverage, ...]:
    out = []
    for a in range(3):
        own = layout.leg == a
        q_all = np.round(layout.q_mm[:, a], 6)
        q_own = sorted_distinct(q_all[own]) if own.any() else sorted_distinct(q_all)
        step = median(np.diff(q_own)) if len(q_own) > 1 else math.inf
        sides = layout.approach[own, a] if own.any() else layout.approach[:, a]
        both = bool((sides > 0).any() and (sides < 0).any())
        finite = travel_mm[:, a][np.isfinite(travel_mm[:, a]) & (travel_mm[:, a] > 0)]
        alias = alias_pitch_mm(q_own, SHORTEST_LEAD_MM / SAMPLES_PER_PERIOD) \
            if len(q_own) >= MIN_POSITIONS else None
        out.append(AxisCoverage(a, len(q_own), float(q_all.min()), float(q_all.max()), step,
                                both, float(finite.min()) if len(finite) else math.inf,
                                display_limited_mm, alias_mm=alias))
    return tuple(out)


@dataclass(frozen=True)
class MapCandidate:
    """A family at its best shape beside the current model."""

    term: MapTerm
    gain: float  # weighted rss it removes
    rank: int  # its columns' rank beside the model
    coefficients: np.ndarray
    shapes_tried: int
    shape_parameters: int  # estimated beyond its amplitudes (pitch, length, tau)
    p_value: float = 1.0  # nested test, corrected for its shapes and the families tried
    delta_bic: float = 0.0
    size_mm: float = 0.0  # its largest displacement: what plausibility judges
    reason: str = ""  # why not taken ("" when eligible)
    shape_std: float = math.nan  # of the shape parameter (pitch mm, build-up mm, tau s)
    # the coefficients' change per unit of it along its profile (a pitch's; None: not
    # known): ``error_maps.ShapeSpread.path``
    shape_path: np.ndarray | None = field(default=None, compare=False)
    unresolved: str = ""  # why its shape is not resolved (then never added)
    # its shape refined between the grid's points, with the shape's std: done only for
    # a candidate that is taken (the test is on the grid, whose multiplicity it counts)
    refine: Callable[[], MapCandidate] | None = field(default=None, repr=False,
                                                       compare=False)

    def refined(self) -> MapCandidate:
        if self.refine is None:
            return self
        better = self.refine()
        return replace(better, p_value=self.p_value, delta_bic=self.delta_bic,
                       size_mm=self.size_mm, reason=self.reason, refine=None)

    @property
    def eligible(self) -> bool:
        return not self.reason

    @property
    def spread(self) -> ShapeSpread:
        return ShapeSpread(self.shape_std, self.shape_path)


@dataclass
class MapStep:
    added: MapCandidate
    considered: list[MapCandidate]
    rss_before: float
    rss_after: float


@dataclass
class MapSearch:
    coverage: tuple[AxisCoverage, ...]
    level: float
    steps: list[MapStep] = field(default_factory=list)
    last_considered: list[MapCandidate] = field(default_factory=list)
    searched: bool = False  # any axis dense enough (or time spread) to search at all
    # cyclic errors the search from the joint offsets alone stopped on, their pitch
    # between rival peaks, where this search's model holds three terms or more
    # (``maps._chosen_route``)
    unresolved_alone: list[MapCandidate] = field(default_factory=list)

    @property
    def terms(self) -> list[MapTerm]:
        return [s.added.term for s in self.steps]

    @property
    def unresolved(self) -> list[MapCandidate]:
        """Cyclic errors seen beyond the noise at the last step but at the band's edge
        or between rival peaks: their pitch is not resolved, so none is given."""
        last = self.last_considered or (self.steps[-1].considered if self.steps else [])
        here = [c for c in last if c.unresolved and c.p_value < self.level]
        named = {c.term.name for c in here}
        return here + [c for c in self.unresolved_alone if c.term.name not in named]


def _variance_left(space: MapSpace, noise: GaugeNoise, gain: float, params: int) -> float:
    """The variance a shape's std is judged against: the gauge noise, or what the model
    leaves unexplained with the term added (``gain``, ``params`` of its own) when that
    is more. Not what it left before: that holds the term's own signal, and made a
    4 um cyclic error's pitch std 3.7 times too wide (its map "loose" for the travel
    at every size), the wider the larger the error."""
    return max(noise.variance, (space.rss - gain) / max(space.dof - params, 1))


def _golden(f: Callable[[float], float], lo: float, hi: float, steps: int = 30) -> float:
    """The maximum of a unimodal ``f`` on [lo, hi] by golden-section search."""
    ratio = (math.sqrt(5) - 1) / 2
    a, b = lo, hi
    c, d = b - ratio * (b - a), a + ratio * (b - a)
    fc, fd = f(c), f(d)
    for _ in range(steps):
        if fc > fd:
            b, d, fd = d, c, fc
            c = b - ratio * (b - a)
            fc = f(c)
        else:
            a, c, fc = c, d, fd
            d = a + ratio * (b - a)
            fd = f(d)
    return (a + b) / 2


def _curvature_std(f: Callable[[float], float], x: float, h: float, var: float) -> float:
    """Std of a shape parameter from the curvature of the gain at its best value: the
    profile chi-square rises by one a std away."""
    second = (f(x + h) - 2 * f(x) + f(x - h)) / h**2
    return math.sqrt(2 * var / -second) if second < 0 else math.inf


class _Families:
    """Every family's best shape on one axis, beside one model."""

    def __init__(self, space: MapSpace, cov: AxisCoverage, names: tuple[str, ...],
                 noise: GaugeNoise) -> None:
        self.space, self.cov, self.names, self.noise = space, cov, names, noise
        self.rep = space.representative
        h = space.history
        self.gauge_rep = space.problem.obs.layout.gauge[self.rep]
        self.q_rep = h.q_mm[self.rep, cov.axis]
        self.q_set = h.setting_q_mm[self.gauge_rep, cov.axis]
        s_r, s_s = space.along
        self.s_rep, self.s_set = s_r[self.rep, cov.axis], s_s[self.rep, cov.axis]
        self._sums_by_bin: dict[float, PositionSums] = {}

    def _sums(self, bin_mm: float) -> PositionSums:
        """The axis's columns' weights summed over positions binned at ``bin_mm``
        (``mapbins.py``), made once for the periodogram and the spline's knots."""
        made = self._sums_by_bin.get(bin_mm)
        if made is None:
            made = PositionSums(self.space, self.q_rep, self.q_set, self.s_rep, self.s_set,
                                bin_mm)
            self._sums_by_bin[bin_mm] = made
        return made

    def _candidate(self, term: MapTerm, gain: Gain, tried: int, shape_params: int,
                   **kw: Any) -> MapCandidate:
        return MapCandidate(term, float(gain.gain[0]), int(gain.rank[0]),
                            gain.coefficients[0], tried, shape_params, **kw)

    def periodic(self, family: str) -> MapCandidate | None:
        cov, a = self.cov, self.cov.axis
        min_pitch, max_pitch = cov.pitch_band_mm
        if not min_pitch < max_pitch:
            return None
        df = 1.0 / (OVERSAMPLE * cov.span_mm)
        freqs = np.arange(1.0 / max_pitch, 1.0 / min_pitch + df / 2, df)
        sums = self._sums(min_pitch / BINS_PER_PITCH)
        gains = np.empty(len(freqs))
        for lo in range(0, len(freqs), CHUNK):
            gains[lo:lo + CHUNK] = sums.gain(freqs[lo:lo + CHUNK], _grid_functions).gain
        best = int(np.argmax(gains))

        def at(f: float) -> float:
            return float(self._periodic_gain(np.array([f])).gain[0])

        def refine() -> MapCandidate:
            top = float(freqs[best])
            found = _golden(at, float(freqs[best - 1]), float(freqs[best + 1]), 20)
            if at(found) > at(top):
                top = found
            gain = self._periodic_gain(np.array([top]))
            var = _variance_left(self.space, self.noise, float(gain.gain[0]),
                                 int(gain.rank[0]) + 1)
            std_f = _curvature_std(at, top, df / 20, var)
            term = MapTerm(family, a, {"pitch_mm": 1.0 / top})
            return self._candidate(term, gain, len(freqs), 1, shape_std=std_f / top**2,
                                   shape_path=self._profile_path(top, df / 20))

        pitch = 1.0 / float(freqs[best])
        term = MapTerm(family, a, {"pitch_mm": pitch})
        if best == len(freqs) - 1:
            unresolved = (f"pitch unresolved (below the band's {min_pitch:.3g} mm edge: "
                          f"{SAMPLES_PER_PERIOD:g} distinct positions a period; a denser "
                          "or irregular scan would resolve it)")
        elif best == 0:
            unresolved = (f"pitch unresolved (beyond the band's {max_pitch:.3g} mm edge: "
                          f"{MIN_PERIODS:g} periods over the span; the smooth map's)")
        else:
            unresolved = _rival_pitch(freqs, gains, best, self.space, self.noise)
        return self._candidate(term, self._periodic_gain(freqs[best:best + 1]), len(freqs),
                               1, refine=None if unresolved else refine,
                               unresolved=unresolved)

    def _profile_path(self, f: float, h: float) -> np.ndarray:
        """The cyclic term's coefficients' change per mm of pitch along its profile at
        frequency ``f`` (refitted at f +- h; dP = -df / f^2)."""
        up, down = (self._periodic_gain(np.array([f + s])).coefficients[0] for s in (h, -h))
        return np.asarray((up - down) / (2 * h) * -(f * f), dtype=float)

    def _periodic_gain(self, freqs: np.ndarray) -> Gain:
        """The exact gains at ``freqs``, column by column at every repeat group."""
        t_rep = _trial_functions(freqs, self.q_rep)  # (F, 2, G)
        t_set = _trial_functions(freqs, self.q_set)
        return self.space.gain_grouped(t_rep * self.s_rep + t_set * self.s_set)

    def searched(self, duration_s: float) -> SearchedAxis:
        cov = self.cov
        travel = self.space.history.travel_mm[:, cov.axis]
        longest = float(np.max(travel[np.isfinite(travel)], initial=0.0))
        return SearchedAxis(cov.axis, cov.positions, cov.from_mm, cov.to_mm, cov.both_sides,
                            cov.shortest_travel_mm, longest, duration_s, self.names)

    def best(self, grid: ShapeGrid) -> MapCandidate:
        """The grid's best shape beside the model, its count the shapes tried."""
        weighed = self._near_best_binned(grid) if grid.by_bic and grid.of_q_alone \
            else grid.terms
        gains = [self.space.gain_of(t) for t in weighed]
        if grid.by_bic:
            n_data = self.space.problem.n_data
            best = int(np.argmin([bic_change(float(g.gain[0]), int(g.rank[0]), n_data,
                                             self.noise) for g in gains]))
        else:
            best = int(np.argmax([float(g.gain[0]) for g in gains]))
        term, gain = weighed[best], gains[best]
        at = grid.terms.index(term)  # its place in the grid, between its neighbours
        refine = None if grid.refine is None else (lambda: self._refined(grid, at, gain))
        return self._candidate(term, gain, len(grid.terms), term.shape_parameters,
                               refine=refine)

    def _near_best_binned(self, grid: ShapeGrid) -> list[MapTerm]:
        """The grid's shapes worth weighing exactly: every one weighed first on the
        positions' sums (exact where the positions are no more than the bins, as a
        scan's at 1 mm; binned at a 32nd of the shortest lead on a denser one, which
        moves a gain by a few units of the noise's variance: 2.1 at most on the
        72,000-reading bench), those within ``SPLINE_MARGIN_KNOTS`` amplitudes' price
        of the best kept."""
        sums = self._sums(SHORTEST_LEAD_MM / BINS_PER_PITCH)
        n_data = self.space.problem.n_data
        binned = [bic_change(float(g.gain[0]), int(g.rank[0]), n_data, self.noise)
                  for t in grid.terms
                  for g in [sums.gain(np.zeros(1), partial(_shape_functions, t))]]
        margin = SPLINE_MARGIN_KNOTS * math.log(max(n_data, 2))
        return [t for t, b in zip(grid.terms, binned, strict=True)
                if b <= min(binned) + margin]

    def _refined(self, grid: ShapeGrid, best: int, gain: Gain) -> MapCandidate:
        """The best shape's parameter ``grid.refine`` refined between its neighbours on
        a log scale (a build-up length), with its std from the gain's curvature."""
        name = grid.refine
        assert name is not None
        values = [t.shape[name] for t in grid.terms]
        term = grid.terms[best]

        std = math.nan
        if 0 < best < len(values) - 1 and values[best - 1] > 0:
            def of_log(x: float) -> float:
                return float(self.space.gain_of(term.reshaped(**{name: math.exp(x)})).gain[0])

            x = _golden(of_log, math.log(values[best - 1]), math.log(values[best + 1]), 16)
            refined = self.space.gain_of(term.reshaped(**{name: math.exp(x)}))
            if refined.gain[0] >= gain.gain[0]:
                term, gain = term.reshaped(**{name: math.exp(x)}), refined
            value = term.shape[name]
            var = _variance_left(self.space, self.noise, float(gain.gain[0]),
                                 int(gain.rank[0]) + term.shape_parameters)
            std = value * _curvature_std(of_log, math.log(value), 0.05, var)
        return self._candidate(term, gain, len(values), term.shape_parameters,
                               shape_std=std)


def _rival_pitch(freqs: np.ndarray, gains: np.ndarray, best: int, space: MapSpace,
                 noise: GaugeNoise) -> str:
    """Why the best pitch is not resolved (empty: it is): another peak of the
    periodogram, apart from the best's, fits within ``SWAP_CHI2`` of it (the swap
    test's three-sigma rule), in units of the variance the best leaves. Readings that
    see a joint strongly only over a stretch shorter than the period (the other legs'
    gauges, over the 16 mm the joint moves while those legs are driven) fit a 15 mm
    pitch there about as well as a 20 mm one."""
    if len(gains) < 3:
        return ""
    var = _variance_left(space, noise, float(gains[best]), 2)
    peaks = local_maxima(gains)
    apart = np.abs(peaks - best) >= OVERSAMPLE  # beyond the best's own main lobe
    close = peaks[apart & (gains[best] - gains[peaks] < SWAP_CHI2 * var)]
    if not len(close):
        return ""
    rival = int(close[np.argmax(gains[close])])
    return (f"{RIVALS}{1.0 / freqs[best]:.4g} and {1.0 / freqs[rival]:.4g} mm fit "
            f"alike (chi-square {(gains[best] - gains[rival]) / var:.2g} apart, under "
            f"{SWAP_CHI2:g}); positions that see this joint over its whole travel would "
            "tell them apart")


def _trial_functions(freqs: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(F, 2, len(q)) the cyclic error's shapes at ``q``: a sine and a cosine less
    one, zero at q = 0 as ``model/error_maps.py`` makes the lead-screw term."""
    w = 2 * np.pi * freqs[:, None, None]
    return np.concatenate([np.sin(w * q), np.cos(w * q) - 1.0], axis=1)


def _shape_functions(term: MapTerm, _freqs: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(1, k, len(q)) a shape of ``q`` alone (the screw map's) as ``PositionSums``
    takes trial functions."""
    n = len(q)
    return term.shape_of(q, np.zeros(n), np.full(n, np.inf), np.zeros(n))[None]


def _grid_functions(freqs: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``_trial_functions`` at evenly spaced ``freqs`` (a chunk of the periodogram's
    grid) by ``mapbins.phasors``: only the grid's scan uses it, the candidate taken is
    weighed on the exact columns."""
    step = freqs[1] - freqs[0] if len(freqs) > 1 else 0.0
    z = phasors(freqs[0], step, len(freqs), q)
    return np.stack([z.imag, z.real - 1.0], axis=1)


def _repeated_in_time(layout: ReadingsLayout) -> bool:
    """Whether postures were read again later (cycles): time is then separable from
    position."""
    return bool(np.any(layout.repeat_size > 1)) and float(np.ptp(layout.t_s)) > 0


def _candidates(space: MapSpace, covs: tuple[AxisCoverage, ...], names: tuple[str, ...],
                noise: GaugeNoise, taken: set[str]) -> list[MapCandidate]:
    layout = space.problem.obs.layout
    duration = float(np.ptp(layout.t_s))
    out: list[MapCandidate] = []
    for cov in covs:
        if not cov.searchable:
            continue
        fam = _Families(space, cov, names, noise)
        for family in FAMILIES.values():
            if family.in_time:
                continue
            if family.periodic:
                periodic = fam.periodic(family.name)
                if periodic is not None:
                    out.append(periodic)
                continue
            out += [fam.best(grid) for grid in family.search(fam.searched(duration))]
    if _repeated_in_time(layout) and space.within_groups_tested:
        for cov in covs:
            fam = _Families(space, cov, names, noise)
            axis = fam.searched(duration)
            out += [fam.best(grid) for family in FAMILIES.values() if family.in_time
                    for grid in family.search(axis)]
    return [c for c in out if c.term.name not in taken]


def _judge(cands: list[MapCandidate], space: MapSpace, noise: GaugeNoise,
           level: float) -> list[MapCandidate]:
    """Each candidate's corrected p, BIC change, size and whether it may be added."""
    if not cands:
        return []
    gains = np.array([c.gain for c in cands])
    ranks = np.array([c.rank for c in cands])
    dof = space.dof - ranks
    _, p = nested_tests(space.rss, space.rss - gains, ranks, dof, noise)
    out = []
    for k, c in enumerate(cands):
        corrected = min(1.0, float(p[k]) * c.shapes_tried * len(cands))
        bic = bic_change(c.gain, c.rank + c.shape_parameters, space.problem.n_data, noise)
        size = c.term.size_mm(c.coefficients)
        if c.rank == 0:
            reason = "nothing of it is left beside the model"
        elif c.unresolved:
            reason = c.unresolved
        elif corrected >= level:
            reason = (f"not significant (p = {corrected:.2g} after {c.shapes_tried} shapes "
                      f"and {len(cands)} families)")
        elif bic >= 0:
            reason = "does not pay for its parameters (BIC)"
        elif size > c.term.kind.plausible_mm:
            reason = f"needs an implausible size ({size * UM_PER_MM:.0f} µm)"
        else:
            reason = ""
        out.append(replace(c, p_value=corrected, delta_bic=bic, size_mm=size, reason=reason))
    return out


def _unresolved_first(judged: list[MapCandidate], level: float) -> bool:
    """Whether the step's best explanation by the BIC, of those beyond the noise, is a
    cyclic error whose pitch lies between rival peaks: nothing is taken then, for
    whatever else were taken would stand in for it, fitted where the readings see the
    joint and a guess beyond (a smooth map of 16 µm, a hysteresis, for a 4 µm error of
    20 mm pitch)."""
    seen = [c for c in judged if c.p_value < level and c.rank > 0]
    best = min(seen, key=lambda c: c.delta_bic, default=None)
    return best is not None and best.unresolved.startswith(RIVALS)


def search_maps(problem: Problem, noise: GaugeNoise, theta: np.ndarray,
                names: tuple[str, ...], rss: float, consistent: bool,
                alpha: float = LEVEL, jacobian: np.ndarray | None = None,
                pitch_band_mm: tuple[float, float] | None = None) -> MapSearch:
    """Forward selection of map terms beside the model ``names`` fitted at ``theta``
    (weighted rss ``rss``; ``jacobian``: its unweighted Jacobian there, when the
    caller holds it); ``consistent``: whether that model is within the noise
    (the search then runs at the stricter level); ``pitch_band_mm``: the periods the
    positions sample, as their design states (None: from their spacing)."""
    level = alpha / STRICTER_WHEN_CONSISTENT if consistent else alpha
    if not problem.obs.raw:
        return MapSearch((), level)
    space = MapSpace(problem, theta, names, rss, jacobian=jacobian)
    # with the display's rounding repeated by the cycles (not dithered by the gauge's
    # scatter), the posture means' errors are the rounding of a signal that varies
    # smoothly along q: a structure of its own, which the maps would fit
    limited = None if noise.dithered else noise.step_mm
    covs = tuple(replace(c, designed_band_mm=pitch_band_mm) for c in
                 coverage(problem.obs.layout, space.history.travel_mm, limited))
    search = MapSearch(covs, level)
    search.searched = any(c.searchable for c in covs) or (
        _repeated_in_time(problem.obs.layout) and space.within_groups_tested)
    if not search.searched:
        return search
    taken: set[str] = set()
    while len(search.steps) < MAX_TERMS:
        judged = _judge(_candidates(space, covs, names, noise, taken), space, noise, level)
        eligible = [c for c in judged if c.eligible]
        if not eligible or _unresolved_first(judged, level):
            search.last_considered = sorted(judged, key=lambda c: c.delta_bic)
            break
        chosen = min(eligible, key=lambda c: c.delta_bic).refined()
        before = space.rss
        space = space.extended(space.weighted(space.unweighted(chosen.term)))
        search.steps.append(MapStep(chosen, sorted(judged, key=lambda c: c.delta_bic),
                                    before, space.rss))
        taken.add(chosen.term.name)
    return search
