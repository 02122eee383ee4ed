"""Fitting parameters of the exact model to observations, in batches.

One routine serves a single refit and a Monte-Carlo of ten thousand: the
parameters of every trial move together, the analytic Jacobian of all trials
and all parameters comes from one call of the vectorised model, and the
Gauss-Newton normal equations are solved as a stack.

Weighting: ordinary least squares (the papers') or generalised least squares
with the deviations' own covariance (eq. 13-14), which is the better estimator
when Zero readings are shared. Raw readings are independent, so both coincide.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from enum import StrEnum

import numpy as np

from ogacq.identify.identifiability import (
    Identifiability,
    assess,
    plausible_ranges,
    rank_of,
    reduced_svd,
)
from ogacq.identify.linear import LINEAR_COLUMNS, design_matrix
from ogacq.identify.noise import GaugeNoise, GroupWhitener, group_whitener, noise_for
from ogacq.identify.observations import Observations
from ogacq.model.measurement import as_slice
from ogacq.model.parameters import NOMINAL, PARAM_NAMES, indices, nested

MAX_ITERATIONS = 30
# Steps below this (relative to each parameter's plausible range) are far below any
# gauge's resolution: the fit has converged.
STEP_TOLERANCE = 1e-8
# A step below this fraction of the tolerance (1e-10 mm for an offset) is not even
# taken: near the minimum Gauss-Newton's steps shrink quadratically (1e-3, 1e-6,
# 1e-12 mm), so its last one is usually of this size, and taking it would cost one
# more evaluation of the model to move by nothing any result shows.
NEGLIGIBLE_STEP = 1e-3
# How often a step that raised the cost is halved before none is taken.
HALVINGS = 8


class StopReason(StrEnum):
    """Why a fit stopped iterating (lmfit's result says it in its ``message``). The
    first four are convergence; a fit that stopped otherwise did not converge."""

    STEP_BELOW_TOLERANCE = "step_below_tolerance"
    NEGLIGIBLE_STEP = "negligible_step"
    COST_STALLED = "cost_stalled"
    NO_DESCENT = "no_descent"
    MAX_ITERATIONS = "max_iterations"
    STEP_FAILED = "step_failed"
    LINEAR_STEP = "linear_step"  # method "linear": one step, nothing to converge
    EVALUATED = "evaluated"  # values given (a recorded result): no iteration

    @property
    def converged(self) -> bool:
        return self not in (StopReason.MAX_ITERATIONS, StopReason.STEP_FAILED)

    def describe(self) -> str:
        return _STOP_REASONS[self]


_STOP_REASONS = {
    StopReason.STEP_BELOW_TOLERANCE: f"converged: the last step was below {STEP_TOLERANCE:g} "
                                     "of each parameter's plausible range",
    StopReason.NEGLIGIBLE_STEP: "converged: the next step would move no parameter by "
                                f"{STEP_TOLERANCE * NEGLIGIBLE_STEP:g} of its plausible range",
    StopReason.COST_STALLED: "converged: the last step no longer lowered the sum of squares",
    StopReason.NO_DESCENT: f"converged: no step, halved {HALVINGS} times, lowered the sum "
                           "of squares",
    StopReason.MAX_ITERATIONS: f"stopped after {MAX_ITERATIONS} iterations, still moving",
    StopReason.STEP_FAILED: f"the model could not be evaluated along the step (no finite sum "
                            f"of squares, halved {HALVINGS} times)",
    StopReason.LINEAR_STEP: "one step of the linearised model, not iterated",
    StopReason.EVALUATED: "evaluated at the values given, not iterated",
}


def _ranges(free: np.ndarray) -> np.ndarray:
    """(p,) the plausible ranges of the parameters at ``free`` (read-only, built once)."""
    return plausible_ranges([PARAM_NAMES[k] for k in np.asarray(free).tolist()])


class Weighting:
    """Maps residuals and Jacobians into the space where the fit is ordinary least
    squares. Raw readings are whitened by their repeat groups' covariance (the
    display rounding the cycles share, ``noise.py``) and the gauge zeros projected
    out there, so the fit is generalised least squares whatever ``kind`` says;
    tabulated deviations are whitened by their covariance for ``kind`` "gls"."""

    def __init__(self, obs: Observations, kind: str, noise: GaugeNoise | None = None) -> None:
        if kind not in ("ols", "gls"):
            raise ValueError(f"weighting must be 'ols' or 'gls', got {kind!r}")
        self.obs = obs
        self.kind = kind
        self.noise = noise or noise_for(obs)
        self.whitener: np.ndarray | None = None
        self.groups: GroupWhitener | None = None
        if obs.raw:
            self.groups = group_whitener(obs, self.noise)
            # each gauge's zero, whitened: what it adds to every reading of that gauge
            self._zero_onehot, self._zero_norm = self.groups.zeros(obs.layout.gauge_onehot)
        elif kind == "gls":
            chol = np.linalg.cholesky(obs.noise_cov)
            self.whitener = np.linalg.inv(chol)

    def residual(self, r: np.ndarray) -> np.ndarray:
        if self.groups is not None:
            w = self.groups(r)
            return w - ((w @ self._zero_onehot) / self._zero_norm) @ self._zero_onehot.T
        return r if self.whitener is None else r @ self.whitener.T

    def residual_and_jac(self, r: np.ndarray, jac: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`residual` of ``r`` (1, m) and :meth:`jac` of ``jac`` (1, m, p) at once,
        the same doubles: the repeat groups whiten every row alike, so the residual
        and the Jacobian's columns go through them as one array; the zeros are
        projected out of each as :meth:`residual` does (a product of another shape
        may sum in another order)."""
        if self.groups is None:
            return self.residual(r), self.jac(jac)
        both = self.groups(np.concatenate([r[:, None, :], jac.swapaxes(-1, -2)], axis=1))
        w, wj = both[:, 0], both[:, 1:]
        zeros, norm = self._zero_onehot, self._zero_norm
        return w - ((w @ zeros) / norm) @ zeros.T, \
            (wj - ((wj @ zeros) / norm) @ zeros.T).swapaxes(-1, -2)

    def jac(self, jac: np.ndarray) -> np.ndarray:
        if self.groups is not None:
            return self.residual(jac.swapaxes(-1, -2)).swapaxes(-1, -2)
        return jac if self.whitener is None else self.whitener @ jac

    def noise_cov(self) -> np.ndarray | None:
        """Noise covariance in the weighted space (units sigma^2); None is identity."""
        if self.obs.raw or self.whitener is not None:
            return None
        return self.obs.noise_cov


def design_rank(jw: np.ndarray, ranges: np.ndarray) -> int:
    """Rank of a weighted Jacobian (m, p), columns scaled to plausible ranges."""
    return rank_of(np.linalg.svd(jw * ranges, compute_uv=False))


def _solve(jw: np.ndarray, rw: np.ndarray, ranges: np.ndarray, rank: int,
           svd: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """Least-squares steps for a stack (B, m, p), truncated to ``rank`` directions so
    that a fit never wanders along combinations the data cannot see. ``svd``: the
    reduced SVD of ``jw * ranges`` when the caller has it."""
    u, s, vt = reduced_svd(jw * ranges) if svd is None else svd
    coef = np.einsum("bmk,bm->bk", u[:, :, :rank], rw) / s[:, :rank]
    return np.einsum("bkp,bk->bp", vt[:, :rank], coef) * ranges


@dataclass(frozen=True)
class _Weighted:
    """A weighted Jacobian (B, m, p) and the reduced SVD of it times the ranges."""

    jac: np.ndarray
    svd: tuple[np.ndarray, np.ndarray, np.ndarray]


def gauss_newton(obs: Observations, y: np.ndarray, free: np.ndarray, theta0: np.ndarray,
                 weighting: Weighting, rank: int | None = None, *,
                 tolerance: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Fit ``free`` entries for each row of ``y`` (B, m) from the full vector
    ``theta0`` (N,): the vectors (B, N) and a converged mask. ``rank``: the
    directions the data determine (all by default); ``tolerance``: per-parameter
    step at which to stop (at least ``STEP_TOLERANCE`` of the plausible ranges)."""
    rank = len(free) if rank is None else rank
    ranges = _ranges(free)
    tol = np.maximum(tolerance, ranges * STEP_TOLERANCE)
    rows = _batch_start(obs, y, free, theta0, weighting)
    for _ in range(MAX_ITERATIONS):
        act, step = _batch_steps(rows, weighting, ranges, rank)
        if not len(act):
            break
        _take_steps(rows, obs, y, free, weighting, act, step, tol)
        if rows.converged.all():
            break
    return rows.theta, rows.converged


@dataclass
class _Batch:
    """The rows of a batched fit where they stand: vectors, Jacobians, weighted residuals
    and costs, which rows have converged, and the weighted Jacobian with its SVD while
    known. Mutable on purpose: an accepted step updates its rows in place (a copy of
    every array per step would cost a Monte-Carlo more than its arithmetic)."""

    theta: np.ndarray  # (B, N)
    jac: np.ndarray  # (B, m, p)
    white: np.ndarray  # (B, m): the next step starts from them
    cost: np.ndarray  # (B,)
    converged: np.ndarray  # (B,) bool
    jw_here: np.ndarray | None  # weighting.jac(jac), while every row is where it was formed
    svd_here: tuple[np.ndarray, np.ndarray, np.ndarray] | None  # of jw_here * ranges

    def moved(self) -> None:
        self.jw_here = self.svd_here = None


def _batch_start(obs: Observations, y: np.ndarray, free: np.ndarray, theta0: np.ndarray,
                 weighting: Weighting) -> _Batch:
    batch = y.shape[0]
    theta = np.repeat(np.asarray(theta0, dtype=float)[None], batch, axis=0)
    # Every row starts at the same point: one evaluation serves them all.
    start, start_jac = obs.predict_and_jacobian(theta[:1], free)
    white = weighting.residual(y - np.repeat(start, batch, axis=0))
    return _Batch(theta, np.repeat(start_jac, batch, axis=0), white,
                  (white**2).sum(axis=1), np.zeros(batch, dtype=bool), None, None)


def _batch_steps(rows: _Batch, weighting: Weighting, ranges: np.ndarray,
                 rank: int) -> tuple[np.ndarray, np.ndarray]:
    """The rows still moving and their least-squares steps."""
    if rows.converged.any():
        act = np.flatnonzero(~rows.converged)
        rows.moved()
        return act, _solve(weighting.jac(rows.jac[act]), rows.white[act], ranges, rank)
    # every row still moving (always so for one fit): the weighted Jacobian kept
    if rows.jw_here is None:
        rows.jw_here = weighting.jac(rows.jac)
    if rows.svd_here is None:
        rows.svd_here = reduced_svd(rows.jw_here * ranges)
    act = np.arange(len(rows.cost))
    return act, _solve(rows.jw_here, rows.white, ranges, rank, rows.svd_here)


def _take_steps(rows: _Batch, obs: Observations, y: np.ndarray, free: np.ndarray,
                weighting: Weighting, act: np.ndarray, step: np.ndarray,
                tol: np.ndarray) -> None:
    """Move each row in ``act`` by its step, halved where it made things worse; a row
    no step improves is at its minimum, as is one whose step no longer lowers the
    cost (ill-conditioned sets jitter along weak directions). The Jacobian is
    evaluated even where a step ends the fit: the covariance is propagated at the
    solution itself (before it, a condition number moves in its ninth digit)."""
    scale = np.ones(len(act))
    todo = np.arange(len(act))
    every = len(act) == len(rows.cost)
    for attempt in range(HALVINGS):
        # every row's full step (always so for one fit): whole arrays, no gathers
        whole = every and attempt == 0
        rows_tried = act if whole else act[todo]
        moved = step if whole else step[todo] * scale[todo, None]
        trial = rows.theta.copy() if whole else rows.theta[rows_tried]  # fancy indexing copies
        trial[:, free] += moved
        small = (np.abs(moved) < tol).all(axis=1)
        trial_pred, trial_jac = obs.predict_and_jacobian(trial, free)
        trial_white = weighting.residual((y if whole else y[rows_tried]) - trial_pred)
        trial_cost = (trial_white**2).sum(axis=1)
        before = rows.cost if whole else rows.cost[rows_tried]
        ok = trial_cost <= before * (1 + 1e-12) + 1e-300
        if whole and ok.all():  # the usual case: every row takes its full step
            rows.converged = small | (trial_cost >= before * (1 - 1e-12))
            rows.theta, rows.cost = trial, trial_cost
            rows.white, rows.jac = trial_white, trial_jac
            rows.moved()
            return
        accepted = rows_tried[ok]
        stalled = trial_cost[ok] >= rows.cost[accepted] * (1 - 1e-12)
        if len(accepted):
            rows.moved()
        rows.theta[accepted], rows.cost[accepted] = trial[ok], trial_cost[ok]
        rows.white[accepted], rows.jac[accepted] = trial_white[ok], trial_jac[ok]
        rows.converged[accepted] = small[ok] | stalled
        todo = todo[~ok]
        if not len(todo):
            return
        scale[todo] *= 0.5
    rows.converged[act[todo]] = True  # no step lowers the cost: at the minimum


@dataclass(frozen=True)
class _Accepted:
    """A step one row took (halved or not), with what the model gave there."""

    theta: np.ndarray  # (1, N)
    pred: np.ndarray
    jac: np.ndarray
    white: np.ndarray
    cost: float
    jw: np.ndarray  # weighting.jac(jac): the next step needs it
    stop: StopReason  # MAX_ITERATIONS while the fit goes on


def _descend_one(obs: Observations, y: np.ndarray, free: np.ndarray, weighting: Weighting,
                 at: slice | np.ndarray, theta: np.ndarray, cost: float, step: np.ndarray,
                 tol_list: list[float]) -> _Accepted | StopReason:
    """The step, halved where it made things worse: where it lowers the cost, or why
    none did (at the minimum where the model could be evaluated, else a failed step)."""
    scale = 1.0
    evaluated = False  # a trial had a finite sum of squares
    for attempt in range(HALVINGS):
        moved = step if attempt == 0 else step * scale
        trial = theta.copy()
        trial[:, at] += moved
        small = _all_below(moved, tol_list)
        trial_pred, trial_jac = obs.predict_and_jacobian(trial, free)
        # the weighted Jacobian with the residuals: an accepted step (the usual case)
        # needs it next
        trial_white, trial_jw = weighting.residual_and_jac(y - trial_pred, trial_jac)
        trial_cost = _cost(trial_white)
        evaluated = evaluated or math.isfinite(trial_cost)
        if trial_cost <= cost * (1 + 1e-12) + 1e-300:
            stop = StopReason.STEP_BELOW_TOLERANCE if small \
                else StopReason.COST_STALLED if trial_cost >= cost * (1 - 1e-12) \
                else StopReason.MAX_ITERATIONS
            return _Accepted(trial, trial_pred, trial_jac, trial_white, trial_cost, trial_jw,
                             stop)
        scale *= 0.5
    return StopReason.NO_DESCENT if evaluated else StopReason.STEP_FAILED


def _iterate_one(obs: Observations, y: np.ndarray, free: np.ndarray, theta0: np.ndarray,
                 weighting: Weighting, rank: int,
                 at_start: tuple[np.ndarray, np.ndarray] | None,
                 weighted_start_jac: np.ndarray | None,
                 start_svd: tuple[np.ndarray, np.ndarray, np.ndarray] | None,
                 start_white: np.ndarray | None = None,
                 ) -> tuple[np.ndarray, int, StopReason, np.ndarray, np.ndarray, _Weighted | None]:
    """:func:`gauss_newton` for one row at the default tolerance (a refit): the same
    steps, decisions and arithmetic, the cost compared as a plain float and without
    the masks and gathers a batch needs, which cost a refit of a few dozen readings
    more than its arithmetic; and why it stopped instead of a converged mask.
    ``start_white``: ``weighting.residual`` of the residuals at ``at_start``, when
    the caller has it."""
    ranges = _ranges(free)
    tol = ranges * STEP_TOLERANCE
    # the steps' tests on plain floats: p is a handful
    tol_list, negligible_below = tol.tolist(), (tol * NEGLIGIBLE_STEP).tolist()
    theta = np.array(theta0, dtype=float)[None]
    at = as_slice(free)  # the free entries, a view when consecutive (the offsets)
    if at_start is None:
        pred, jac = obs.predict_and_jacobian(theta, free)
        white, jw_start = weighting.residual_and_jac(y - pred, jac)
        jw_here: np.ndarray | None = jw_start
        svd_here = None
    else:
        pred, jac = at_start
        jw_here = weighted_start_jac
        svd_here = start_svd if jw_here is not None else None
        white = weighting.residual(y - pred) if start_white is None else start_white
    cost = _cost(white)
    stop = StopReason.MAX_ITERATIONS  # unless it stops for another reason first
    iterations = 0
    while iterations < MAX_ITERATIONS:
        iterations += 1
        if jw_here is None:
            jw_here = weighting.jac(jac)
        if svd_here is None:
            svd_here = reduced_svd(jw_here * ranges)
        step = _solve(jw_here, white, ranges, rank, svd_here)
        if _all_below(step, negligible_below):
            stop = StopReason.NEGLIGIBLE_STEP  # at the minimum where it stands
            break
        taken = _descend_one(obs, y, free, weighting, at, theta, cost, step, tol_list)
        if isinstance(taken, StopReason):
            stop = taken
            break
        theta, pred, cost, white, jac = taken.theta, taken.pred, taken.cost, taken.white, \
            taken.jac
        jw_here, svd_here = taken.jw, None  # vectors moved
        stop = taken.stop
        if stop is not StopReason.MAX_ITERATIONS:
            break
    known = None if jw_here is None or svd_here is None else _Weighted(jw_here, svd_here)
    return theta, iterations, stop, jac, pred, known


def _cost(white: np.ndarray) -> float:
    """The sum of squares of one row (1, m) of weighted residuals: ``(white**2).sum(axis=1)``,
    the same reduction."""
    return float(np.add.reduce(white * white, axis=1)[0])


def _all_below(step: np.ndarray, bounds: list[float]) -> bool:
    """Whether every entry of one row (1, p) is below its bound in magnitude."""
    return all(abs(v) < b for v, b in zip(step[0].tolist(), bounds, strict=True))


@dataclass
class FitResult:
    names: tuple[str, ...]
    values: np.ndarray
    std: np.ndarray  # NaN where a parameter is not determined by the data
    covariance: np.ndarray  # propagated from the gauge noise
    residuals: np.ndarray  # observed minus predicted (gauge zeros removed), mm
    residual_rms_mm: float
    sigma_mm: float  # sqrt(RSS / dof): the noise these residuals imply
    dof: int
    noise: GaugeNoise  # the gauge noise the std are propagated from
    identifiability: Identifiability
    method: str
    weighting: str
    iterations: int
    stop_reason: StopReason
    theta: np.ndarray  # the full parameter vector at the solution
    observations: Observations
    jacobian: np.ndarray  # (m, p) of the predictions at the solution, unweighted

    @property
    def converged(self) -> bool:
        return self.stop_reason.converged

    @property
    def rss(self) -> float:
        return float(np.sum(self.residuals**2))

    def value(self, name: str) -> float:
        return float(self.values[self.names.index(name)])

    def to_json(self, params_label: str) -> dict:
        """The ``ogacq refit --json`` object of INTERCHANGE.md."""
        ident = self.identifiability
        cond = ident.condition_number
        return {
            "params": params_label,
            "parameters": nested(self.names, [round(float(v), 6) for v in self.values]),
            "std": nested(self.names, [None if not np.isfinite(s) else round(float(s), 6)
                                       for s in self.std]),
            "residual_rms_mm": round(self.residual_rms_mm, 6),
            "sigma_mm": None if not np.isfinite(self.sigma_mm) else round(self.sigma_mm, 6),
            "dof": self.dof,
            "condition_number": round(cond, 4) if np.isfinite(cond) else None,
            "identifiable": ident.identifiable,
            "correlated_pairs": [[a, b, round(c, 4)] for a, b, c in ident.correlated_pairs],
        }


def fit(obs: Observations, names: Sequence[str], *, method: str = "exact",
        weighting: str = "ols", noise: GaugeNoise | None = None,
        theta0: np.ndarray | None = None) -> FitResult:
    """Identify ``names`` from ``obs``: ``method`` "exact" iterates the exact model to
    convergence; "linear" is one step of the linearised model from ``theta0`` (the
    papers' eq. 11 when fitting offsets and lengths to deviations)."""
    if method not in ("linear", "exact"):
        raise ValueError(f"method must be 'linear' or 'exact', got {method!r}")
    names = tuple(names)
    free = indices(names)
    theta0 = NOMINAL.copy() if theta0 is None else np.asarray(theta0, dtype=float)
    noise = noise or noise_for(obs)
    w = Weighting(obs, weighting, noise)
    y = obs.values[None]

    ranges = _ranges(free)
    at_start = start_white = None
    if _uses_design_matrix(obs, names, theta0):
        jac = _linear_jacobian(obs, names, free, theta0)
        jw_start = w.jac(jac)
    else:  # the exact Jacobian there, which the iterations start from too
        at_start = obs.predict_and_jacobian(theta0[None], free)
        jac = at_start[1]
        start_white, jw_start = w.residual_and_jac(y - at_start[0], jac)
    start_svd = reduced_svd(jw_start * ranges)
    rank = rank_of(start_svd[1][0])
    end: _Weighted | None = None
    if method == "linear":
        base = obs.predict(theta0[None])
        step = _solve(jw_start, w.residual(y - base), ranges, rank, start_svd)[0]
        theta = theta0.copy()
        theta[free] += step
        residuals = obs.remove_zeros(y - base - np.einsum("bmp,p->bm", jac, step))[0]
        iterations, stop = 1, StopReason.LINEAR_STEP
    else:
        th, iterations, stop, jac, pred, end = _iterate_one(
            obs, y, free, theta0, w, rank, at_start, jw_start, start_svd, start_white)
        if rank < len(names):
            # Some parameters act only once others have moved the geometry (a gauge's
            # position or gain matters only on a tilted leg): judge the rank again
            # where the determined ones put us, and finish from there.
            rank_there = design_rank(w.jac(jac)[0], ranges) if end is None else \
                rank_of(end.svd[1][0])
            if rank_there > rank:
                rank = rank_there
                th, more, stop, jac, pred, end = _iterate_one(obs, y, free, th[0], w, rank,
                                                              None, None, None)
                iterations += more
        theta = th[0]
        residuals = obs.remove_zeros(y - pred)[0]
    return _result_at(obs, names, free, theta, theta0, jac, residuals, rank, w, method,
                      iterations, stop, end)


def evaluate(obs: Observations, names: Sequence[str], values: Sequence[float]) -> FitResult:
    """The exact fit's result at ``values`` already identified (a campaign's recorded
    result), without iterating: residuals, covariance and identifiability there."""
    names = tuple(names)
    free = indices(names)
    w = Weighting(obs, "ols", noise_for(obs))
    theta = NOMINAL.copy()
    theta[free] = np.asarray(values, dtype=float)
    rank = design_rank(w.jac(_linear_jacobian(obs, names, free, NOMINAL))[0], _ranges(free))
    jac = obs.jacobian(theta[None], free)
    residuals = obs.remove_zeros(obs.values[None] - obs.predict(theta[None]))[0]
    return _result_at(obs, names, free, theta, NOMINAL, jac, residuals, rank, w, "exact", 0,
                      StopReason.EVALUATED)


def _result_at(obs: Observations, names: tuple[str, ...], free: np.ndarray, theta: np.ndarray,
               theta0: np.ndarray, jac: np.ndarray, residuals: np.ndarray, rank: int,
               w: Weighting, method: str, iterations: int, stop_reason: StopReason,
               weighted: _Weighted | None = None) -> FitResult:
    """The statistics of a solution ``theta`` with its (1, m, p) Jacobian ``jac``
    (``weighted``: ``w.jac(jac)`` and its scaled SVD, when known); ``free``: the
    positions of ``names``."""
    noise = w.noise
    # A set the design cannot determine is judged at the start: far along its
    # null directions the curvature makes any Jacobian look full-rank.
    judged = jac
    if rank < len(names):
        weighted = None
        judged = _linear_jacobian(obs, names, free, theta0)
    if weighted is None:
        ident, cov = assess(w.jac(judged)[0], w.noise_cov(), names, noise.sigma_mm)
    else:
        u, s, vt = weighted.svd
        ident, cov = assess(weighted.jac[0], w.noise_cov(), names, noise.sigma_mm,
                            scaled_svd=(u[0], s[0], vt[0]))
    dof = len(obs) - obs.n_nuisance - ident.rank
    rss = float(np.sum(residuals**2))
    return FitResult(
        names=names, values=theta[free], std=np.sqrt(cov.diagonal()), covariance=cov,
        # np.mean's own steps: the sum over the count
        residuals=residuals, residual_rms_mm=math.sqrt(rss / len(residuals)),
        sigma_mm=float(np.sqrt(rss / dof)) if dof > 0 else float("nan"), dof=dof,
        noise=noise, identifiability=ident, method=method, weighting=w.kind,
        iterations=iterations, stop_reason=stop_reason, theta=theta, observations=obs,
        jacobian=jac[0])


def _uses_design_matrix(obs: Observations, names: tuple[str, ...], theta0: np.ndarray,
                        ) -> bool:
    """Deviations fitted for offsets and lengths from nominal: the papers' eq. 11."""
    return (obs.kind == "deviations" and bool(np.allclose(theta0, NOMINAL))
            and set(names) <= set(LINEAR_COLUMNS))


def _linear_jacobian(obs: Observations, names: tuple[str, ...], free: np.ndarray,
                     theta0: np.ndarray) -> np.ndarray:
    if _uses_design_matrix(obs, names, theta0):
        cols = [LINEAR_COLUMNS.index(n) for n in names]
        return design_matrix(obs.labels, obs.machine)[:, cols][None]
    return obs.jacobian(theta0[None], free)
