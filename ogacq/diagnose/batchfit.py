"""Fit many candidate models of one data set at once.

The candidates free different parameters beside a common model, so
``gauss_newton`` (one free set per batch) does not apply; they share its solution
as their start. One Jacobian there, decomposed once (QR), serves them all in a chord
Gauss-Newton whose residuals are the exact model's, a chunk of candidates per
vectorised call: at real effects' magnitudes the Jacobian barely changes over a
step, so three iterations reach the exact fit to far below the gauge noise."""

from __future__ import annotations

import copy
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from ogacq.diagnose.gaugesums import GaugeSums
from ogacq.diagnose.groupspace import GroupSpace
from ogacq.diagnose.locate import RowLabels, row_labels
from ogacq.identify.fit import Weighting
from ogacq.identify.identifiability import RANK_TOLERANCE
from ogacq.identify.noise import GaugeNoise, noise_for
from ogacq.identify.observations import Observations
from ogacq.model.parameters import AXES, NOMINAL, PARAM_INDEX, PARAM_NAMES, effect_of, indices

_DRIFT = indices([f"thermal_drift.{a}" for a in AXES])
# each parameter's plausible range, by its position in the full vector: gathered for a
# whole batch at once (a name lookup per parameter per candidate was a Python loop
# over thousands of entries a diagnosis)
_PLAUSIBLE_RANGE = np.array([effect_of(name).plausible_range for name in PARAM_NAMES])
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
        # raw readings: zeros and weighting by sums, on the calling thread (gaugesums.py)
        self._sums = GaugeSums(obs, self.weighting) if obs.raw else None

    def with_side(self, side: np.ndarray) -> Problem:
        """This problem with the model's lost-motion side replaced
        (``ReadingsLayout.with_side``): everything else reads the recorded approach,
        the gauges and the values, never the side, so it is shared."""
        obs = replace(self.obs, layout=self.obs.layout.with_side(side))
        out = copy.copy(self)
        out.obs = obs
        if self.group_space is not None:
            out.__dict__["group_space"] = self.group_space.with_side(obs)
        return out

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
        return self.remove_zeros(self.obs.values[None] - self.predict(theta))

    def remove_zeros(self, x: np.ndarray) -> np.ndarray:
        """:meth:`Observations.remove_zeros` along the last axis."""
        return self.obs.remove_zeros(x) if self._sums is None else self._sums.remove_zeros(x)

    def weighted(self, residuals: np.ndarray) -> np.ndarray:
        """:meth:`Weighting.residual` along the last axis."""
        if self._sums is None:
            return self.weighting.residual(residuals)
        return self._sums.weighted(residuals)

    def weighted_residuals(self, theta: np.ndarray) -> np.ndarray:
        """(B, m) weighted residuals; the weighting projects the gauge zeros out itself,
        so the unweighted removal of :meth:`residuals` is skipped."""
        return self.weighted(self.obs.values[None] - self.predict(theta))

    @cached_property
    def labels(self) -> RowLabels:
        """What each observation belongs to (``locate.row_labels``), found once."""
        return row_labels(self.obs)

    @cached_property
    def group_space(self) -> GroupSpace | None:
        """Raw readings on their repeat groups' means, where candidates without
        drift are fitted; None for tabulated deviations (no repeats)."""
        return GroupSpace(self.obs, self.weighting) if self.obs.raw else None

    def jacobian(self, theta: np.ndarray, names: Sequence[str],
                 weighted: bool = True) -> np.ndarray:
        """(m, p) derivatives of the observations by the named parameters at ``theta``
        (analytic), weighted unless asked otherwise."""
        theta = np.asarray(theta, float)
        free = np.array(indices(names), dtype=int)
        # a dense scan's from its nodes (GroupSpace.reading_jacobian), where time
        # does not move the poses
        jac = self.group_space.reading_jacobian(theta, free) \
            if self.group_space is not None and not theta[_DRIFT].any() else None
        if jac is None:
            jac = self.obs.jacobian(theta[None], free)[0]
        return self.weighted_jacobian(jac) if weighted else jac

    def weighted_jacobian(self, jac: np.ndarray) -> np.ndarray:
        """The weighting of :meth:`jacobian` applied to an unweighted Jacobian (m, p)
        of the observations the caller holds (a fit's at its solution)."""
        if self._sums is None:
            return self.weighting.jac(jac[None])[0]
        return self._sums.weighted(jac.T).T


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
        an explanation needing a 20 % gauge gain error is no explanation. The candidates
        adding as many parameters are judged as one gather (a step weighs hundreds)."""
        out = np.ones(len(self.extras), dtype=bool)
        sizes = np.array([len(e) for e in self.extras], dtype=int)
        for size in dict.fromkeys(sizes.tolist()):
            rows = np.flatnonzero(sizes == size)
            at = np.array([[PARAM_INDEX[n] for n in self.extras[k]] for k in rows.tolist()],
                          dtype=int).reshape(len(rows), size)
            within = np.abs(self.theta[rows[:, None], at] - NOMINAL[at]) <= _PLAUSIBLE_RANGE[at]
            out[rows] = within.all(axis=1)
        return out


@dataclass
class Design:
    """A weighted Jacobian ``jw`` (m, U) of the parameters ``names`` at one
    parameter vector, with its QR factors once asked for: a caller that needs both
    (the capability table and the first step of the selection) decomposes it once."""

    names: tuple[str, ...]
    jw: np.ndarray

    @cached_property
    def factors(self) -> tuple[np.ndarray, np.ndarray]:
        """``q`` (m, k) orthonormal and ``r`` (k, U), ``jw = q r``, k = min(m, U)."""
        q, r = np.linalg.qr(self.jw)
        return q, r


def fit_many(problem: Problem, theta_start: np.ndarray, model: Sequence[str],
             candidates: Sequence[Sequence[str]], jac: Design | None = None) -> CandidateFits:
    """Fit ``model + extra`` for every extra of ``candidates``, each started from
    ``theta_start`` (the model's own solution). ``jac``: the weighted Jacobian at
    ``theta_start`` when the caller already holds one covering the names fitted on every
    reading."""
    model = tuple(model)
    extras = [tuple(e) for e in candidates]
    theta_start = np.asarray(theta_start, dtype=float)
    out = CandidateFits(model, extras, np.repeat(theta_start[None], len(extras), axis=0),
                        np.empty(len(extras)), np.empty(len(extras), dtype=int))
    if not extras:
        return out
    free = [np.array(indices(model + e), dtype=int) for e in extras]
    # Without thermal drift, raw readings are fitted on their repeat groups' means
    # (exact, ``groupspace.py``); with it, on every reading.
    start_drifts = bool(np.any(theta_start[_DRIFT] != 0.0))
    drift = set(_DRIFT.tolist())
    on_groups = np.array([problem.group_space is not None and not start_drifts
                          and drift.isdisjoint(f.tolist()) for f in free])
    for grouped in (True, False):
        chosen = np.flatnonzero(on_groups == grouped)
        if not len(chosen):
            continue
        names = tuple(dict.fromkeys(model + tuple(n for k in chosen for n in extras[k])))
        space = _Space.build(problem, theta_start, names, grouped, jac)
        for size in sorted({len(extras[k]) for k in chosen}):
            rows = np.array([k for k in chosen if len(extras[k]) == size])
            cols = np.array([[space.position[n] for n in model + extras[k]] for k in rows],
                            dtype=int)
            theta, rss, rank = _chord(space, theta_start, cols, np.array([free[k] for k in rows]))
            out.theta[rows], out.rss[rows], out.rank[rows] = theta, rss, rank
    return out


@dataclass(frozen=True)
class _Space:
    """Where candidates are fitted: ``residuals`` (B, N) -> (B, m) weighted, the QR
    factors of the weighted Jacobian at the common start (``q`` (m, k), ``r`` (k, U)
    of the columns of ``position``), the start's residuals along ``q`` and what
    every fit there adds to its sum of squares. A candidate's Jacobian is ``q``
    times its columns of ``r``: its SVD is a (k, p) one, and the m-row products are
    ``einsum`` sums on the calling thread (gaugesums.py says why)."""

    residuals: Callable[[np.ndarray], np.ndarray]
    position: dict[str, int]
    q: np.ndarray
    r: np.ndarray
    start: np.ndarray  # (k,) coordinates of the start's residuals along q
    start_rss: float
    constant: float

    @classmethod
    def build(cls, problem: Problem, theta_start: np.ndarray, names: tuple[str, ...],
              on_groups: bool, jac: Design | None) -> _Space:
        """The space of the repeat groups' means or of every observation, for
        candidates freeing at most ``names``."""
        space = problem.group_space if on_groups else None
        nodes = space.node_space(theta_start) if space is not None else None
        if nodes is not None:  # a dense scan: its nodes' rows (posenodes.NodeSpace)
            design = Design(names, nodes.jacobian(theta_start, np.array(indices(names))))
            residuals, constant, start = nodes.residuals, nodes.constant, nodes.start
        elif space is not None:
            # G rows: decomposed directly, whatever the caller holds
            design = Design(names, space.jacobian_at(theta_start, names))
            residuals, constant = space.residuals, space.constant_rss
            start = space.start_at(theta_start)  # where every candidate starts
        else:
            if jac is None or not set(names) <= set(jac.names):
                jac = Design(names, problem.jacobian(theta_start, names))
            design, residuals, constant = jac, problem.weighted_residuals, 0.0
            start = residuals(theta_start[None])[0]
        q, r = design.factors
        return cls(residuals, {n: k for k, n in enumerate(design.names)}, q, r,
                   _along(start[None], q)[0], float(np.sum(start**2)), constant)


def _along(r: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(B, k) coordinates of the rows of ``r`` (B, m) along the columns of ``q``."""
    return np.einsum("bm,mk->bk", r, q)


def _chord(space: _Space, theta_start: np.ndarray, cols: np.ndarray, free: np.ndarray,
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The chord fits of candidates of one size in ``space``, a chunk at a time so
    that the (B, m) arrays stay within ``CHUNK_VALUES`` however long the campaign.
    Each candidate's fit is independent of the others'."""
    batch = len(cols)
    theta = np.empty((batch, len(theta_start)))
    rss = np.empty(batch)
    rank = np.empty(batch, dtype=int)
    chunk = max(1, CHUNK_VALUES // max(len(space.q), 1))
    for lo in range(0, batch, chunk):
        part = slice(lo, lo + chunk)
        theta[part], rss[part], rank[part] = _chord_chunk(space, theta_start, cols[part],
                                                          free[part])
    return theta, rss + space.constant, rank


def _chord_chunk(space: _Space, theta_start: np.ndarray, cols: np.ndarray, free: np.ndarray,
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Chord Gauss-Newton of a batch in ``space``, every candidate from ``theta_start``."""
    batch, p = cols.shape
    ranges = _PLAUSIBLE_RANGE[free]  # (B, p)
    a = np.moveaxis(space.r[:, cols], 0, 1) * ranges[:, None, :]  # (B, k, p), plausible units
    u, s, vt = np.linalg.svd(a, full_matrices=False)
    keep = s > s[:, :1] * RANK_TOLERANCE
    inv_s = np.where(keep, 1.0 / np.where(keep, s, 1.0), 0.0)
    rows = np.arange(batch)[:, None]

    theta = np.repeat(theta_start[None], batch, axis=0)
    along = np.repeat(space.start[None], batch, axis=0)  # residuals' coordinates along q
    rss = np.full(batch, space.start_rss)
    moving = np.arange(batch)  # candidates whose last step lowered their cost
    for iteration in range(CHORD_ITERATIONS):
        coef = np.einsum("bkj,bk->bj", u[moving], along[moving]) * inv_s[moving]
        step = np.einsum("bjp,bj->bp", vt[moving], coef) * ranges[moving]
        trial = theta[moving]
        trial[rows[:len(moving)], free[moving]] += step
        r_trial = space.residuals(trial)
        rss_trial = np.sum(r_trial**2, axis=1)
        # A step that does not lower the cost is beyond the fixed Jacobian's reach
        # and stays so: from the same point the same step would be tried again, so
        # that candidate is not evaluated any more.
        better = rss_trial < rss[moving]
        moving = moving[better]
        theta[moving], rss[moving] = trial[better], rss_trial[better]
        if not len(moving):
            break
        if iteration + 1 < CHORD_ITERATIONS:
            along[moving] = _along(r_trial[better], space.q)
    return theta, rss, keep.sum(axis=1)
