"""A plain numpy Gauss-Newton fit of the joint offsets: the floor the project's fit is
measured against (bench_linear.py). Written apart from ogacq's model on purpose: the
nominal machine in closed form, the analytic Jacobian by implicit differentiation,
the same weighting (repeat groups whitened, gauge zeros projected out), nothing else.

Nominal machine: joint ``i`` at ``rho_i e_i`` (``rho = L + q + offset``), every leg
``L`` long, gauges set halfway along their leg (MODEL.md).
"""

from __future__ import annotations

import numpy as np


def tcp(rho: np.ndarray, leg_mm: float) -> np.ndarray:
    """(m, 3) TCP of the nominal machine: ``|p - rho_i e_i| = L`` gives
    ``p_i = a_i s + b_i`` with ``s = |p|^2``, and ``s`` solves a quadratic; the
    assembly mode is the root nearer the origin."""
    a = 0.5 / rho
    b = (rho**2 - leg_mm**2) * a
    qa = np.sum(a * a, axis=1)
    qb = 2.0 * np.sum(a * b, axis=1) - 1.0
    qc = np.sum(b * b, axis=1)
    s = (-qb - np.sqrt(qb * qb - 4.0 * qa * qc)) / (2.0 * qa)
    return a * s[:, None] + b


def tcp_by_offsets(p: np.ndarray, rho: np.ndarray) -> np.ndarray:
    """(m, 3, 3) ``dp / d offset_k`` (last axis k): ``(p - r_i) . (dp - e_i d rho_i) = 0``."""
    rows = p[:, None, :] - rho[:, :, None] * np.eye(3)  # row i: p - r_i
    rhs = np.zeros_like(rows)
    idx = np.arange(3)
    rhs[:, idx, idx] = p - rho  # equation i, offset k = i
    return np.linalg.solve(rows, rhs)


class OffsetsFloor:
    """Readings of one campaign, fitted for the three joint offsets."""

    def __init__(self, q, leg, axis, gauge, setting_q, group, values, leg_mm: float,
                 within_var: float, shared_var: float, variance: float) -> None:
        self.q, self.leg, self.axis, self.gauge = q, leg, axis, gauge
        self.set_q = setting_q
        self.set_leg = np.array([leg[np.flatnonzero(gauge == g)[0]]
                                 for g in range(len(setting_q))])
        self.values, self.leg_mm = values, leg_mm
        self.group = group
        self.size = np.bincount(group).astype(float)
        within = max(within_var, variance / 100.0)
        self.within_scale = np.sqrt(variance / within)
        self.mean_scale = np.sqrt(variance / (within + self.size * shared_var))
        zeros = np.eye(len(setting_q))[gauge] * self.mean_scale[group][:, None]
        self.zeros = zeros / np.linalg.norm(zeros, axis=0)

    def predict(self, offsets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(n,) readings up to the gauge zeros and (n, 3) their offset derivatives."""
        n, k = len(self.q), np.arange(len(self.q))
        rho = self.leg_mm + np.concatenate([self.q, self.set_q]) + offsets
        p = tcp(rho, self.leg_mm)
        dp = tcp_by_offsets(p, rho)
        i, j, g, s = self.leg, self.axis, self.gauge, self.set_leg
        drho = np.eye(3)
        set_rows = n + np.arange(len(self.set_q))
        p0, dp0 = p[set_rows, s], dp[set_rows, s]
        plane = 0.5 * (p0 + rho[set_rows, s])
        dplane = 0.5 * (dp0 + drho[s])
        pi, pj, ri = p[k, i], p[k, j], rho[k, i]
        mu = (plane[g] - pi) / (ri - pi)
        dmu = (dplane[g] - dp[k, i] - mu[:, None] * (drho[i] - dp[k, i])) / (ri - pi)[:, None]
        return pj * (1.0 - mu), dp[k, j] * (1.0 - mu)[:, None] - pj[:, None] * dmu

    def whiten(self, x: np.ndarray) -> np.ndarray:
        """Repeat groups whitened along the first axis, then the gauge zeros removed."""
        shape = (len(self.size),) + x.shape[1:]
        sums = np.zeros(shape)
        np.add.at(sums, self.group, x)
        means = (sums.T / self.size).T[self.group]
        w = (x - means) * self.within_scale + (means.T * self.mean_scale[self.group]).T
        return w - self.zeros @ (self.zeros.T @ w)

    def fit(self, iterations: int = 30, tolerance_mm: float = 1e-7) -> np.ndarray:
        offsets = np.zeros(3)
        for _ in range(iterations):
            predicted, jac = self.predict(offsets)
            step = np.linalg.lstsq(self.whiten(jac), self.whiten(self.values - predicted),
                                   rcond=None)[0]
            offsets = offsets + step
            if np.max(np.abs(step)) < tolerance_mm:
                break
        return offsets
