"""Fit many candidate models of one data set at once.

Each candidate frees its own parameters beside a common model (the joint offsets
and the effects chosen so far), so the candidates do not share a free set and the
identification engine's ``gauss_newton`` (one free set per batch) does not apply.
They do share a starting point: the common model's solution. One Jacobian of
every parameter there serves all candidates, and the batch is iterated with that
fixed Jacobian (a chord Gauss-Newton) while each residual is the exact model's,
evaluated for all candidates in one vectorised call. At the magnitudes of real
effects the Jacobian barely changes over a candidate's step, so three iterations
reach the exact least-squares fit to far below the gauge noise.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ogacq.diagnose.groupspace import GroupSpace
from ogacq.identify.fit import Weighting
from ogacq.identify.identifiability import RANK_TOLERANCE
from ogacq.identify.noise import GaugeNoise, noise_for
from ogacq.identify.observations import Observations
from ogacq.model.parameters import AXES, PARAM_NAMES, effect_of, indices

_DRIFT = indices([f"thermal_drift.{a}" for a in AXES])
CHORD_ITERATIONS = 3
# Candidates are fitted in chunks of at most this many (candidate, row) values per
# array, or one candidate when a single one has more: memory then grows with the
# readings, not readings x candidates. The size is set by speed, not memory: the
# model's evaluation makes dozens of temporaries of this size, and while each fits
# in a core's own cache (1 MiB, 131,072 float64, on the 2-core machine of issue 14,
# as on most cores since 2017) a candidate costs about half of what it costs when
# they spill to the shared cache or memory (72,000 readings: 8 ms an evaluation per
# candidate alone, 14 ms batched by 13).
CHUNK_VALUES = 100_000


class Problem:
    """A data set in the space where fitting is ordinary least squares: gauge zeros
    projected out and, for tabulated deviations, whitened by their covariance."""

    def __init__(self, obs: Observations, noise: GaugeNoise | None = None) -> None:
        self.obs = obs
        self.noise = noise or noise_for(obs)
        self.weighting = Weighting(obs, "gls", self.noise)
        self.n_data = len(obs) - obs.n_nuisance  # independent observations

    def predict(self, theta: np.ndarray) -> np.ndarray:
        """(B, m) predictions. Rows with thermal drift need every reading's pose
        solved, the others only the distinct poses: predict them apart."""
        drift = np.any(theta[:, _DRIFT] != 0.0, axis=1)
        if drift.all() or not drift.any():
            return self.obs.predict(theta)
        out = np.empty((len(theta), len(self.obs)))
        out[drift] = self.obs.predict(theta[drift])
        out[~drift] = self.obs.predict(theta[~drift])
        return out

    def residuals(self, theta: np.ndarray) -> np.ndarray:
        """(B, m) observed minus predicted, gauge zeros removed (mm), unweighted."""
        return self.obs.remove_zeros(self.obs.values[None] - self.predict(theta))

    def weighted(self, residuals: np.ndarray) -> np.ndarray:
        return self.weighting.residual(residuals)

    def weighted_residuals(self, theta: np.ndarray) -> np.ndarray:
        """(B, m) weighted residuals; the weighting projects the gauge zeros out itself,
        so the unweighted removal of :meth:`residuals` is skipped."""
        return self.weighted(self.obs.values[None] - self.predict(theta))

    @cached_property
    def group_space(self) -> GroupSpace | None:
        """Raw readings on their repeat groups' means, where candidates without
        drift are fitted; None for tabulated deviations (no repeats)."""
        return GroupSpace(self.obs, self.weighting) if self.obs.raw else None

    def jacobian(self, theta: np.ndarray, names: Sequence[str],
                 weighted: bool = True) -> np.ndarray:
        """(m, p) derivatives of the observations by the named parameters at ``theta``
        (analytic), weighted unless asked otherwise."""
        jac = self.obs.jacobian(np.asarray(theta, float)[None], indices(names))
        return self.weighting.jac(jac)[0] if weighted else jac[0]


@dataclass
class CandidateFits:
    """The least-squares fits of a model extended by each of ``extras``."""

    model: tuple[str, ...]
    extras: list[tuple[str, ...]]
    theta: np.ndarray  # (B, N) full parameter vectors at each fit
    rss: np.ndarray  # (B,) weighted residual sums of squares, mm^2
    rank: np.ndarray  # (B,) parameters the data determine, model's included

    def values(self, k: int) -> np.ndarray:
        return self.theta[k, indices(self.extras[k])]

    def full_rank(self) -> np.ndarray:
        sizes = np.array([len(self.model) + len(e) for e in self.extras])
        return self.rank == sizes

    def plausible(self) -> np.ndarray:
        """Candidates whose fitted values lie within each effect's plausible range:
        an explanation needing a 20 % gauge gain error is no explanation."""
        out = np.ones(len(self.extras), dtype=bool)
        for k, extra in enumerate(self.extras):
            for name, value in zip(extra, self.values(k), strict=True):
                kind = effect_of(name)
                out[k] &= abs(value - kind.nominal) <= kind.plausible_range
        return out


def fit_many(problem: Problem, theta_start: np.ndarray, model: Sequence[str],
             extras: Sequence[Sequence[str]], iterations: int = CHORD_ITERATIONS,
             jac: tuple[tuple[str, ...], np.ndarray] | None = None) -> CandidateFits:
    """Fit ``model + extra`` for every extra, each started from ``theta_start`` (the
    model's own solution). ``jac``: the weighted Jacobian (names, (m, U)) at
    ``theta_start`` when the caller already holds one covering all the names."""
    model = tuple(model)
    extras = [tuple(e) for e in extras]
    theta_start = np.asarray(theta_start, dtype=float)
    out = CandidateFits(model, extras, np.repeat(theta_start[None], len(extras), axis=0),
                        np.empty(len(extras)), np.empty(len(extras), dtype=int))
    if not extras:
        return out
    union = tuple(dict.fromkeys(model + tuple(n for e in extras for n in e)))
    if jac is None or not set(union) <= set(jac[0]):
        jac = (union, problem.jacobian(theta_start, union))
    jac_names, jw = jac
    position = {n: k for k, n in enumerate(jac_names)}
    sizes = sorted({len(e) for e in extras})
    spaces = _Spaces(problem, theta_start, jw)
    for size in sizes:
        rows = np.array([k for k, e in enumerate(extras) if len(e) == size])
        names = [model + extras[k] for k in rows]
        cols = np.array([[position[n] for n in ns] for ns in names], dtype=int)
        free = np.array([indices(ns) for ns in names], dtype=int)
        theta, rss, rank = _chord(spaces, cols, free, iterations)
        out.theta[rows], out.rss[rows], out.rank[rows] = theta, rss, rank
    return out


class _Spaces:
    """Where candidates are fitted, each with its residual function, the weighted
    Jacobian there and the residuals at the common start: the repeat groups' means
    (candidates without drift, raw readings) or every observation. Built when first
    asked and shared by the candidates of every size."""

    def __init__(self, problem: Problem, theta_start: np.ndarray, jw: np.ndarray) -> None:
        self.problem, self.theta_start, self._jw = problem, theta_start, jw
        self._built: dict[bool, tuple[Callable, np.ndarray, np.ndarray, float]] = {}

    def get(self, on_groups: bool) -> tuple[Callable[[np.ndarray], np.ndarray], np.ndarray,
                                            np.ndarray, float]:
        """(residuals, jacobian, start residuals, rss constant) of one space."""
        if on_groups not in self._built:
            fitted = self.problem.group_space if on_groups else None
            if fitted is None:
                residuals, jw, constant = self.problem.weighted_residuals, self._jw, 0.0
            else:
                residuals, jw = fitted.residuals, fitted.jacobian(self._jw)
                constant = fitted.constant_rss
            start = residuals(self.theta_start[None])[0]  # where every candidate starts
            self._built[on_groups] = (residuals, jw, start, constant)
        return self._built[on_groups]


def _chord(spaces: _Spaces, cols: np.ndarray, free: np.ndarray,
           iterations: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The chord fits of candidates of one size. Without thermal drift they are fitted
    on the repeat groups' means (exact, ``groupspace.py``); the others on every
    reading, a chunk at a time so that the (B, m) arrays stay within
    ``CHUNK_VALUES`` however long the campaign. Each candidate's fit is
    independent of the others'."""
    theta_start = spaces.theta_start
    batch = len(cols)
    theta = np.empty((batch, len(theta_start)))
    rss = np.empty(batch)
    rank = np.empty(batch, dtype=int)
    drifts = np.isin(free, _DRIFT).any(axis=1) | bool(np.any(theta_start[_DRIFT] != 0.0))
    on_groups = spaces.problem.group_space is not None
    for rows, grouped in ((np.flatnonzero(~drifts), on_groups), (np.flatnonzero(drifts), False)):
        if not len(rows):
            continue
        residuals, jw_here, start, constant = spaces.get(grouped)
        chunk = max(1, CHUNK_VALUES // max(len(jw_here), 1))
        for lo in range(0, len(rows), chunk):
            part = rows[lo:lo + chunk]
            theta[part], rss[part], rank[part] = _chord_chunk(
                residuals, theta_start, start, jw_here, cols[part], free[part], iterations)
        rss[rows] += constant
    return theta, rss, rank


def _chord_chunk(residuals: Callable[[np.ndarray], np.ndarray], theta_start: np.ndarray,
                 start: np.ndarray, jw: np.ndarray, cols: np.ndarray, free: np.ndarray,
                 iterations: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Chord Gauss-Newton of a batch; ``residuals`` (B, N) -> (B, m) weighted, in the
    space of the rows of ``jw``, ``start`` (m,) theirs at ``theta_start``."""
    batch, p = cols.shape
    ranges = np.array([[effect_of(PARAM_NAMES[k]).plausible_range for k in row]
                       for row in free])
    a = np.moveaxis(jw[:, cols], 0, 1) * ranges[:, None, :]  # (B, m, p), plausible units
    u, s, vt = np.linalg.svd(a, full_matrices=False)
    del a
    keep = s > s[:, :1] * RANK_TOLERANCE
    inv_s = np.where(keep, 1.0 / np.where(keep, s, 1.0), 0.0)
    rows = np.arange(batch)[:, None]

    theta = np.repeat(theta_start[None], batch, axis=0)
    r = np.repeat(start[None], batch, axis=0)
    rss = np.sum(r**2, axis=1)
    moving = np.arange(batch)  # candidates whose last step lowered their cost
    for _ in range(iterations):
        coef = np.einsum("bmk,bm->bk", u[moving], r[moving]) * inv_s[moving]
        step = np.einsum("bkp,bk->bp", vt[moving], coef) * ranges[moving]
        trial = theta[moving]
        trial[rows[:len(moving)], free[moving]] += step
        r_trial = residuals(trial)
        rss_trial = np.sum(r_trial**2, axis=1)
        # A step that does not lower the cost is beyond the fixed Jacobian's reach
        # and stays so: from the same point the same step would be tried again, so
        # that candidate is not evaluated any more.
        better = rss_trial < rss[moving]
        moving = moving[better]
        theta[moving], r[moving], rss[moving] = trial[better], r_trial[better], \
            rss_trial[better]
        if not len(moving):
            break
    return theta, rss, keep.sum(axis=1)
