"""Where error-map candidates are tested: the weighted residual of the current model,
the directions it has fitted, and every candidate's columns in the same space.

A map term is linear in its amplitudes and moves the joints by micrometres, so
beside a fitted model its columns are the joint sensitivities
(``model/joint_sensitivity.py``) times its shape, and a candidate's gain is a
projection, exact for the linear model:

    gain = r' C (C' P C)^+ C' r,   P = I - B B'   (B: the model's directions)

Columns constant over each repeat group (every shape along ``q``) are formed at one
reading per group, in the group coordinates of ``noise.GroupWhitener`` (the same
inner products with any whitened vector): a periodogram over 72,000 readings costs
what it does over their few thousand postures. Columns varying within a group
(time, a hysteresis after different travels) are weighted reading by reading."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ogacq.diagnose.batchfit import Problem
from ogacq.diagnose.gaugesums import PerGauge
from ogacq.identify.identifiability import RANK_TOLERANCE
from ogacq.model.error_maps import JointHistory, MapTerm
from ogacq.model.joint_sensitivity import JointSensitivity, joint_sensitivity

# Below this share of its own norm a column is taken as absorbed by the model.
ABSORBED = 1e-10


@dataclass(frozen=True)
class Gain:
    """What adding columns to the current model would remove from its weighted rss:
    ``gain`` (F,), the columns' rank beside the model (F,), the coefficients (F, k)."""

    gain: np.ndarray
    rank: np.ndarray
    coefficients: np.ndarray


class MapSpace:
    """The weighted residual and fitted directions of a model of raw readings, at its
    parameter vector ``theta``, and map columns in that space."""

    def __init__(self, problem: Problem, theta: np.ndarray, names: tuple[str, ...],
                 rss: float, jacobian: np.ndarray | None = None) -> None:
        obs = problem.obs
        assert obs.raw, "error maps are searched in raw readings"
        self.problem = problem
        self.theta = np.asarray(theta, dtype=float)
        groups = problem.weighting.groups
        assert groups is not None
        self.groups = groups
        self.history = JointHistory.of(obs.layout)
        # the model's unweighted Jacobian at theta, when its caller holds it
        jw = problem.jacobian(self.theta, names) if jacobian is None \
            else problem.weighted_jacobian(jacobian)
        self.basis = _orthonormal(jw)
        r = problem.weighted_residuals(self.theta[None])[0]
        self.r = r - self.basis @ (self.basis.T @ r)  # the model's own directions out
        self.rss = float(rss)
        self.rank = self.basis.shape[1]
        # one reading per repeat group, and the group coordinates of the zero directions
        n_groups = len(groups.size)
        first = np.full(n_groups, len(obs))
        np.minimum.at(first, groups.group, np.arange(len(obs)))
        self.representative = first
        self._gauge_of_group = obs.layout.gauge[first]
        self._mean_dir = groups.mean_scale * np.sqrt(groups.size)
        zero_norm2 = np.bincount(self._gauge_of_group, weights=self._mean_dir**2)
        self._zero_norm2 = np.maximum(zero_norm2, np.finfo(float).tiny)
        self._per_gauge = PerGauge(self._gauge_of_group, len(self._zero_norm2))
        self.r_groups = groups.group_space(self.r)
        self.basis_groups = groups.group_space(self.basis.T)  # (p, G)

    @property
    def dof(self) -> int:
        return self.problem.n_data - self.rank

    @cached_property
    def sensitivity(self) -> JointSensitivity:
        return joint_sensitivity(self.theta, self.problem.obs.layout, self.problem.obs.machine)

    @cached_property
    def along(self) -> tuple[np.ndarray, np.ndarray]:
        """(n, 3) each: every reading's sensitivity to each joint along its line, at the
        reading's pose and at its gauge's setting pose."""
        return self.sensitivity.along()

    # --- columns ---------------------------------------------------------------------

    def unweighted(self, term: MapTerm, rows: np.ndarray | None = None) -> np.ndarray:
        """(k, len(rows)) the term's effect on the readings at ``rows`` (all: None) per
        unit amplitude, mm."""
        return term_columns(term, self.history, self.sensitivity, self.along,
                            self.problem.obs.layout.gauge, rows)

    def grouped(self, term: MapTerm) -> bool:
        """Whether the term's columns are constant over every repeat group."""
        if term.kind.grouped is not None:  # a shape of q and the side: the group's key
            return term.kind.grouped
        cols = self.unweighted(term)
        means = self.groups.group_means(cols)[:, self.groups.group]
        return bool(np.allclose(cols, means, rtol=0.0, atol=1e-12 * max(
            float(np.abs(cols).max(initial=0.0)), 1e-300)))

    def group_coordinates(self, values: np.ndarray) -> np.ndarray:
        """(..., G) group coordinates of whitened columns whose unweighted values are
        ``values`` (..., G) at the groups' representative readings: scaled as a group
        mean is whitened, each gauge's zero projected out."""
        x = np.asarray(values, dtype=float) * self._mean_dir
        flat = x.reshape(-1, x.shape[-1])
        out = self._per_gauge.project_out(flat, self._mean_dir, self._zero_norm2)
        return out.reshape(x.shape)

    def weighted(self, columns: np.ndarray) -> np.ndarray:
        """(k, n) reading-space weighting of unweighted columns (k, n)."""
        return self.problem.weighted(columns)

    # --- gains ----------------------------------------------------------------------

    def gain_grouped(self, values: np.ndarray) -> Gain:
        """Gains of candidates whose columns are ``values`` (F, k, G) at the groups'
        representative readings (unweighted)."""
        c = self.group_coordinates(values)
        cc = np.einsum("fkg,flg->fkl", c, c)
        cb = np.einsum("fkg,pg->fkp", c, self.basis_groups)
        cr = np.einsum("fkg,g->fk", c, self.r_groups)
        return _gains(cc, cb, cr)

    def gain_weighted(self, columns_w: np.ndarray) -> Gain:
        """Gains of one candidate whose weighted columns are ``columns_w`` (k, n)."""
        cc = columns_w @ columns_w.T
        cb = columns_w @ self.basis
        cr = columns_w @ self.r
        return _gains(cc[None], cb[None], cr[None])

    @property
    def within_groups_tested(self) -> bool:
        """Whether what varies between the cycles can be tested: only against a stated
        noise whose rounding the scatter dithers (repeats rounded alike differ by whole
        steps; a noise measured from the repeats is that very scatter)."""
        noise = self.problem.noise
        return noise.dithered and not noise.measured

    def gain_of(self, term: MapTerm) -> Gain:
        """The gain of ``term``'s columns; those that vary within the repeat groups by
        every reading, or by their groups' means where that variation cannot be
        tested (``within_groups_tested``)."""
        if self.grouped(term):
            return self.gain_grouped(self.unweighted(term, self.representative)[None])
        cols = self.unweighted(term)
        if not self.within_groups_tested:
            means = self.groups.group_means(cols)[:, self.groups.group]
            return self.gain_grouped(means[:, self.representative][None])
        return self.gain_weighted(self.weighted(cols))

    # --- the model grown by chosen columns ----------------------------------------------

    def extended(self, columns_w: np.ndarray) -> MapSpace:
        """This space with the weighted columns (k, n) added to the model's directions
        (the residual refitted linearly)."""
        new = object.__new__(MapSpace)
        new.__dict__.update({k: v for k, v in self.__dict__.items()
                             if k not in ("basis", "r", "rss", "rank", "r_groups",
                                          "basis_groups")})
        rest = columns_w.T - self.basis @ (self.basis.T @ columns_w.T)
        extra = _orthonormal(rest, relative_to=np.linalg.norm(columns_w, axis=1))
        gain = float(np.sum((extra.T @ self.r) ** 2))
        new.basis = np.column_stack([self.basis, extra])
        new.r = self.r - extra @ (extra.T @ self.r)
        new.rss = self.rss - gain
        new.rank = new.basis.shape[1]
        new.r_groups = self.groups.group_space(new.r)
        new.basis_groups = self.groups.group_space(new.basis.T)
        return new


def term_columns(term: MapTerm, history: JointHistory, sensitivity: JointSensitivity,
                 along: tuple[np.ndarray, np.ndarray], gauge: np.ndarray,
                 rows: np.ndarray | None = None) -> np.ndarray:
    """(k, len(rows)) a map term's effect on the readings at ``rows`` (all: None) per
    unit amplitude: its displacement at each reading's pose and at its gauge's
    setting pose, times the readings' sensitivities to them (mm)."""
    rows = np.arange(len(history.q_mm)) if rows is None else rows
    shape_r, shape_s = term.columns(history, rows)
    s_r, s_s = term.kind.sensitivities(term, sensitivity, along)
    return shape_r * s_r[rows] + shape_s[:, gauge[rows]] * s_s[rows]


def _orthonormal(columns: np.ndarray, relative_to: np.ndarray | None = None) -> np.ndarray:
    """An orthonormal basis (m, rank) of the columns (m, p), each column scaled to unit
    norm first (so units do not decide the rank); columns whose norm is below
    ``ABSORBED`` of ``relative_to`` (their norms before a projection) are dropped."""
    if columns.size == 0:
        return np.zeros((columns.shape[0], 0))
    norms = np.linalg.norm(columns, axis=0)
    ref = norms if relative_to is None else relative_to
    live = norms > np.sqrt(ABSORBED) * np.maximum(ref, np.finfo(float).tiny)
    if not live.any():
        return np.zeros((columns.shape[0], 0))
    scaled = columns[:, live] / norms[live]
    u, s, _ = np.linalg.svd(scaled, full_matrices=False)
    return u[:, s > s[0] * RANK_TOLERANCE] if len(s) else u[:, :0]


def _gains(cc: np.ndarray, cb: np.ndarray, cr: np.ndarray) -> Gain:
    """Gains from the raw inner products: ``cc`` (F, k, k) columns with columns, ``cb``
    (F, k, p) with the model's orthonormal directions, ``cr`` (F, k) with the residual
    (orthogonal to those directions)."""
    diag = np.einsum("fkk->fk", cc)
    projected = cc - np.einsum("fkp,flp->fkl", cb, cb)
    scale = np.sqrt(np.maximum(diag, np.finfo(float).tiny))
    if cc.shape[1] == 1:  # one column: its share of the residual, no decomposition
        left = projected[:, 0, 0] / diag[:, 0].clip(np.finfo(float).tiny)
        keep1 = (left > ABSORBED) & (diag[:, 0] > 0)
        denom = np.where(keep1, projected[:, 0, 0], 1.0)
        gain1 = np.where(keep1, cr[:, 0] ** 2 / denom, 0.0)
        return Gain(gain1, keep1.astype(int), np.where(keep1, cr[:, 0] / denom, 0.0)[:, None])
    a = projected / scale[:, :, None] / scale[:, None, :]
    values, vectors = np.linalg.eigh(a)
    keep = values > np.maximum(values[:, -1:], 0.0) * 1e-9
    keep &= values > ABSORBED
    inv = np.where(keep, 1.0 / np.where(keep, values, 1.0), 0.0)
    b = cr / scale
    along = np.einsum("fkj,fk->fj", vectors, b)
    gain = np.sum(along**2 * inv, axis=1)
    coef = np.einsum("fkj,fj->fk", vectors, along * inv) / scale
    return Gain(gain, keep.sum(axis=1), coef)
