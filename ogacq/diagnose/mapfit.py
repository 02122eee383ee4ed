"""The final model with error maps: the library's parameters by the exact model and
the maps' amplitudes beside them, fitted together; its verdict, std, the maps as
``AxisMap`` tables, and what each effect is worth.

Gauss-Newton on ``y = h(theta) + sum_k M_k c_k``, ``M_k`` a term's columns (the
joints' sensitivities times its shape, first order: ``model/joint_sensitivity.py``),
weighted as ``fit.Weighting`` does, the step truncated to the directions the data
determine, columns scaled first (the library's by their plausible ranges, the
maps' by their norms)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace

import numpy as np

from ogacq.diagnose.batchfit import Problem
from ogacq.diagnose.mapspace import term_columns
from ogacq.identify.consistency import LEVEL, Verdict, judge
from ogacq.identify.fit import FitResult, StopReason
from ogacq.identify.identifiability import RANK_TOLERANCE, judge_covariance, plausible_ranges
from ogacq.identify.noise import GaugeNoise
from ogacq.model.axis_map import AxisMap
from ogacq.model.error_maps import (
    NO_SPREAD,
    JointHistory,
    MapTerm,
    ShapeSpread,
    axis_map,
    tabulation_step,
    terms_json,
)
from ogacq.model.gauges import AXES
from ogacq.model.joint_sensitivity import JointSensitivity, joint_sensitivity
from ogacq.model.parameters import indices

ITERATIONS = 6
STEP_TOLERANCE = 1e-9  # of each column's scale: far below any gauge's resolution


@dataclass
class MapFit:
    """The library parameters ``names`` at ``theta`` beside the map ``terms`` with
    their ``coefficients``; ``covariance`` of all of them (library first, then the
    terms' amplitudes in order), from the gauge noise."""

    names: tuple[str, ...]
    theta: np.ndarray
    terms: list[MapTerm]
    coefficients: list[np.ndarray]
    covariance: np.ndarray
    residuals: np.ndarray  # unweighted, gauge zeros removed, mm
    rss: float  # weighted
    rank: int
    jacobian: np.ndarray  # (n, p + K) unweighted: the library's, then the maps'
    verdict: Verdict
    converged: bool
    # (n,) weighted, of which ``rss`` is the sum of squares: what a linearisation about
    # this fit starts from (``mapswap.linearised``)
    weighted_residuals: np.ndarray = field(repr=False, compare=False)

    @property
    def p(self) -> int:
        return len(self.names)

    def term_slice(self, k: int) -> slice:
        start = self.p + sum(t.size for t in self.terms[:k])
        return slice(start, start + self.terms[k].size)

    def term_covariance(self, k: int) -> np.ndarray:
        s = self.term_slice(k)
        return self.covariance[s, s]

    def std(self, name: str) -> float:
        k = self.names.index(name)
        return float(math.sqrt(max(self.covariance[k, k], 0.0)))


def map_columns(problem: Problem, theta: np.ndarray, terms: list[MapTerm],
                history: JointHistory,
                sensitivity: tuple[JointSensitivity, tuple[np.ndarray, np.ndarray]] | None
                = None) -> np.ndarray:
    """(n, K) the terms' columns at ``theta``, unweighted. ``sensitivity``: the
    readings' ``joint_sensitivity`` at ``theta`` and its ``along()``, when the caller
    holds them."""
    if not terms:
        return np.zeros((len(problem.obs), 0))
    if sensitivity is None:
        sens = joint_sensitivity(theta, problem.obs.layout, problem.obs.machine)
        sensitivity = sens, sens.along()
    sens, along = sensitivity
    gauge = problem.obs.layout.gauge
    return np.vstack([term_columns(t, history, sens, along, gauge) for t in terms]).T


def fit_with_maps(problem: Problem, noise: GaugeNoise, names: tuple[str, ...],
                  theta0: np.ndarray, terms: list[MapTerm], history: JointHistory,
                  alpha: float = LEVEL, iterations: int = ITERATIONS,
                  jacobian0: np.ndarray | None = None) -> MapFit:
    """The library parameters ``names`` and the map ``terms`` fitted together from
    ``theta0`` (``jacobian0``: the unweighted Jacobian of ``names`` there, when the
    caller holds it)."""
    theta = np.asarray(theta0, dtype=float).copy()
    free = indices(names)
    coef = np.zeros(sum(t.size for t in terms))
    ranges = plausible_ranges(list(names))
    converged = False
    for iteration in range(iterations):
        _, _, rw, scale, (u, s, vt, keep) = _linearised(problem, names, theta, terms, history,
                                                         coef, ranges,
                                                         jacobian0 if iteration == 0 else None)
        step = (vt[keep].T @ ((u[:, keep].T @ rw) / s[keep])) * scale
        theta[free] += step[:len(names)]
        coef = coef + step[len(names):]
        if np.all(np.abs(step) <= STEP_TOLERANCE * scale):
            converged = True
            break
    x, raw, rw, scale, (_, s, vt, keep) = _linearised(problem, names, theta, terms, history,
                                                      coef, ranges, None)
    residuals = problem.remove_zeros(raw[None])[0]
    rank = int(keep.sum())
    inv = (vt[keep].T / s[keep] ** 2) @ vt[keep]
    covariance = noise.variance * inv * scale[:, None] * scale[None, :]
    # a shape found from the readings (a pitch) spends a degree of freedom as well
    verdict = judge(problem.obs, residuals, x, rank + sum(t.shape_parameters for t in terms), noise,
                    alpha)
    split = np.cumsum([0] + [t.size for t in terms])
    return MapFit(names, theta, list(terms),
                  [coef[split[k]:split[k + 1]] for k in range(len(terms))], covariance,
                  residuals, float(rw @ rw), rank, x, verdict, converged, rw)


def _linearised(problem: Problem, names: tuple[str, ...], theta: np.ndarray,
                terms: list[MapTerm], history: JointHistory, coef: np.ndarray,
                ranges: np.ndarray, jac: np.ndarray | None,
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, tuple]:
    """At ``theta``: the columns (library, then maps; ``jac`` the library's when known),
    the residuals, the weighted ones, the columns' scales, the scaled weighted SVD."""
    jac = problem.jacobian(theta, names, weighted=False) if jac is None else jac
    cols = map_columns(problem, theta, terms, history)
    x = np.column_stack([jac, cols])
    raw = problem.obs.values - problem.predict(theta[None])[0] - cols @ coef
    xw = problem.weighted(x.T).T
    rw = problem.weighted(raw[None])[0]
    scale = np.concatenate([ranges, 1.0 / np.maximum(np.linalg.norm(xw[:, len(names):],
                                                                    axis=0), 1e-300)])
    u, s, vt = np.linalg.svd(xw * scale, full_matrices=False)
    return x, raw, rw, scale, (u, s, vt, s > s[0] * RANK_TOLERANCE)


def as_fit_result(fitted: MapFit, library: FitResult) -> FitResult:
    """The library's parameters of the final model as the ``FitResult`` the rest of the
    tool reads (offsets, std, residuals): std from the joint covariance, the maps'
    amplitudes beside them (from the gauge noise, as a fit's: a reader inflates
    them as it does any fit's)."""
    p = fitted.p
    cov = fitted.covariance[:p, :p]
    values = fitted.theta[indices(fitted.names)]
    dof = max(fitted.verdict.dof, 1)
    # judged on the joint covariance: the library's own fit may have held other
    # parameters (those a map made redundant), and a map may correlate with an offset
    identifiability = judge_covariance(fitted.names, cov)
    return replace(library, names=fitted.names, values=values,
                   identifiability=identifiability,
                   std=np.sqrt(np.maximum(np.diag(cov), 0.0)), covariance=cov,
                   residuals=fitted.residuals,
                   residual_rms_mm=float(np.sqrt(np.mean(fitted.residuals**2))),
                   sigma_mm=float(math.sqrt(fitted.rss / dof)),
                   dof=fitted.verdict.dof, theta=fitted.theta, jacobian=fitted.jacobian[:, :p],
                   stop_reason=StopReason.STEP_BELOW_TOLERANCE if fitted.converged
                   else StopReason.MAX_ITERATIONS)


def axis_maps(fitted: MapFit, inflation: float, ranges: Mapping[int, tuple[float, float]],
              steps: Mapping[int, float], spreads: Mapping[str, ShapeSpread] | None = None,
              zero_at: Mapping[int, float] | None = None) -> tuple[AxisMap, ...]:
    """One ``AxisMap`` per axis with a map along its line, its terms summed, the band
    from their joint covariance (times ``inflation``) and their shapes' std
    (``spreads`` by term name: a pitch's); zero at the terms' reference, or at the
    axis's ``zero_at`` (``error_maps.axis_map``)."""
    out = []
    for axis in range(3):
        ks = [k for k, t in enumerate(fitted.terms) if t.tabulated and t.axis == axis]
        if not ks:
            continue
        terms = [fitted.terms[k] for k in ks]
        idx = np.concatenate([np.arange(fitted.term_slice(k).start, fitted.term_slice(k).stop)
                              for k in ks])
        cov = fitted.covariance[np.ix_(idx, idx)] * inflation**2
        excludes = tuple(n for n in fitted.names
                         if n in (f"encoder_scale.{AXES[axis]}", f"backlash.{AXES[axis]}"))
        lo, hi = ranges[axis]
        extra: dict = {"families": [t.family for t in terms], "terms": terms_json(terms)}
        for t in terms:
            extra.update(t.kind.table_extra(t))
        source = "; ".join(t.kind.source(t) for t in terms)
        spread = [(spreads or {}).get(t.name, NO_SPREAD).scaled(inflation) for t in terms]
        out.append(axis_map(terms, [fitted.coefficients[k] for k in ks], cov, lo, hi,
                            tabulation_step(terms, steps.get(axis)), source=source,
                            excludes=excludes, extra=extra, spreads=spread,
                            zero_at=(zero_at or {}).get(axis)))
    return tuple(out)

