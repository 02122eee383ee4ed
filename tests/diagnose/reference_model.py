"""An independent forward model of the Orthoglide's gauge readings, written from
../shared/spec/MODEL.md alone, and a brute-force fitter: the reference the error maps
are checked against. Nothing of ogacq is imported here.

MODEL.md: joint i sits at r_i = (rho_i + drho_i) e_i with rho_i = L + q_i; the TCP p
satisfies |p - r_i| = L for the three legs, on the origin side; a gauge on leg i
measuring along j is fixed in space at its leg's middle at the posture where it was
set, and reads the j coordinate of the leg line (through r_i and p) where it crosses
the plane x_i = const. Errors of the axes are added to the joints here as this file
defines them, independently of ogacq's definitions:

* a cyclic lead-screw error: the joint is A sin(2 pi q / P + phi) further along;
* a polynomial screw error sum_k c_k (q / 100)^k;
* a rail bow: the joint centre moves across its line, toward world axis c, by
  s (1 - xi^2), xi = (2 q - (lo + hi)) / (hi - lo);
* hysteresis: moving in direction d after travelling s since the last reversal, the
  joint lags by -d B / 2 (1 - 2 exp(-s / lam)); s counted reading by reading with a
  plain loop.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares
from scipy.stats import chi2

L = 310.25  # the prototype's leg, mm (MODEL.md)


@dataclass
class Physics:
    offsets: tuple[float, float, float] = (0.0, 0.0, 0.0)
    cyclic: dict[int, tuple[float, float, float]] = field(default_factory=dict)  # A, P, deg
    polynomial: dict[int, tuple[float, ...]] = field(default_factory=dict)
    bow: dict[int, tuple[int, float, float, float]] = field(default_factory=dict)  # c, s, lo, hi
    hysteresis: dict[int, tuple[float, float]] = field(default_factory=dict)  # B, lam


def travel_and_side(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per reading and joint: the direction of the last move (0 before any) and the
    travel since the last reversal (inf before one), by walking the readings."""
    n = len(q)
    side = np.zeros((n, 3), dtype=int)
    travel = np.full((n, 3), np.inf)
    for a in range(3):
        d, t, reversed_once = 0, np.inf, False
        for k in range(n):
            if k:
                step = q[k, a] - q[k - 1, a]
                if abs(step) > 1e-9:
                    new = 1 if step > 0 else -1
                    if d != 0 and new != d:
                        t, reversed_once = abs(step), True
                    elif d == 0:
                        t = abs(step)
                        reversed_once = True
                    else:
                        t += abs(step)
                    d = new
            side[k, a] = d
            travel[k, a] = t if reversed_once else np.inf
    return side, travel


def joint_centres(q: np.ndarray, physics: Physics, side: np.ndarray | None = None,
                  travel: np.ndarray | None = None) -> np.ndarray:
    """(n, 3, 3): joint i's centre, row i."""
    n = len(q)
    r = np.zeros((n, 3, 3))
    for i in range(3):
        along = L + q[:, i] + physics.offsets[i]
        if i in physics.cyclic:
            amp, pitch, deg = physics.cyclic[i]
            along = along + amp * np.sin(2 * np.pi * q[:, i] / pitch + np.radians(deg))
        if i in physics.polynomial:
            x = q[:, i] / 100.0
            along = along + sum(c * x ** (k + 1) for k, c in enumerate(physics.polynomial[i]))
        if i in physics.hysteresis and side is not None:
            lost, lam = physics.hysteresis[i]
            along = along - side[:, i] * lost / 2 * (1 - 2 * np.exp(-travel[:, i] / lam))
        r[:, i, i] = along
        if i in physics.bow:
            c, sag, lo, hi = physics.bow[i]
            xi = (2 * q[:, i] - (lo + hi)) / (hi - lo)
            r[:, i, c] += sag * (1 - xi**2)
    return r


def tcp(r: np.ndarray) -> np.ndarray:
    """Solve |p - r_i| = L by Newton's method from the origin side (p = 0)."""
    p = np.zeros((len(r), 3))
    for _ in range(50):
        diff = p[:, None, :] - r  # (n, 3, 3)
        f = np.sum(diff**2, axis=2) - L**2  # (n, 3)
        jac = 2 * diff
        step = np.linalg.solve(jac, f[..., None])[..., 0]
        p = p - step
        if np.max(np.abs(step)) < 1e-13:
            break
    return p


def readings(q: np.ndarray, leg: np.ndarray, axis: np.ndarray, physics: Physics,
             frac: float = 0.5) -> np.ndarray:
    """Noise-free readings (up to each gauge's zero) of gauges (axis j on leg i), each
    set at the pose of its first reading."""
    side, travel = travel_and_side(q)
    r = joint_centres(q, physics, side, travel)
    p = tcp(r)
    n = np.arange(len(q))
    i, j = leg.astype(int), axis.astype(int)
    gauge = gauge_index(leg, axis)
    first = np.array([np.flatnonzero(gauge == g)[0] for g in range(gauge.max() + 1)])
    # the gauge's plane: its leg's middle along the leg's own axis where it was set
    planes = p[first, i[first]] + frac * (r[first, i[first], i[first]] - p[first, i[first]])
    mu = (planes[gauge] - p[n, i]) / (r[n, i, i] - p[n, i])
    return p[n, j] + mu * (r[n, i, j] - p[n, j])


def gauge_index(leg: np.ndarray, axis: np.ndarray) -> np.ndarray:
    keys = {}
    return np.array([keys.setdefault((int(i), int(j)), len(keys))
                     for i, j in zip(leg, axis, strict=True)])


@dataclass
class ReferenceFit:
    params: np.ndarray
    chi2: float
    dof: int

    @property
    def p_value(self) -> float:
        return float(chi2.sf(self.chi2, self.dof))


def fit(q, leg, axis, values, sigma, unknowns, start) -> ReferenceFit:
    """Brute force: ``scipy.optimize.least_squares`` of the ``unknowns(x) -> Physics``
    parameters ``x`` from ``start``, numerical Jacobian; every gauge's zero is its mean
    residual (the least-squares zero for any ``x``), counted in the degrees of freedom."""
    gauge = gauge_index(leg, axis)
    count = np.bincount(gauge)

    def residual(x):
        r = values - readings(q, leg, axis, unknowns(x))
        return (r - (np.bincount(gauge, weights=r) / count)[gauge]) / sigma

    result = least_squares(residual, np.asarray(start, float), x_scale="jac", xtol=1e-12,
                           ftol=1e-12, gtol=1e-12)
    return ReferenceFit(result.x, float(np.sum(result.fun**2)),
                        len(values) - len(start) - len(count))
