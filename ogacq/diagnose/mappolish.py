"""A periodic term's pitch fitted again with the whole final model, and its std from it.

The search refines a pitch at the step that took it, beside the model as it stood
then (``mapsearch._Families.periodic``). The final model holds more: terms taken
later, effects dropped, offsets refitted. Over 150 seeds of ``bench/table_coverage.py``
the pitch so found sat where the final model's chi-square was not lowest (a 6 um lead
of 7.92 mm found at 7.874 mm while the truth fitted the final model better by 1.1), and
its std from the step's curvature was 0.75 of the final model's: cyclic maps held the
truth within their U (k = 2) at 93 % of positions. Here the pitch is a parameter of the
final least-squares problem (the Gauss-Newton step of the full model, its column the
term's derivative by the pitch; Frisch-Waugh-Lovell: the step and the variance are
those of that column less its projection on the others), iterated while it moves, and
its std and profile path are that problem's.
"""

from __future__ import annotations

import math

import numpy as np

from ogacq.diagnose.batchfit import Problem
from ogacq.diagnose.mapfit import MapFit, fit_with_maps, map_columns
from ogacq.identify.identifiability import RANK_TOLERANCE
from ogacq.identify.noise import GaugeNoise
from ogacq.model.error_maps import JointHistory, ShapeSpread

ROUNDS = 4  # Gauss-Newton steps at most: the search's pitch is already near
MOVED = 0.05  # of its std: a step smaller than this leaves the pitch as it is
MOST_STEPS = 3.0  # stds a step may take at once (a flat profile's step is damped)
RELATIVE_H = 1e-6  # of the pitch: the central difference of the term's columns


Spreads = dict[str, ShapeSpread]


def polished(problem: Problem, noise: GaugeNoise, fitted: MapFit, history: JointHistory,
             spreads: Spreads, alpha: float) -> tuple[MapFit, Spreads]:
    """``fitted`` with each periodic term's pitch at the final model's least squares,
    and ``spreads`` with their std and path from it."""
    periodic = [k for k, term in enumerate(fitted.terms) if term.kind.periodic]
    out = dict(spreads)
    for done in range(ROUNDS + 1):  # the last only measures where the pitches ended
        moved = False
        basis = _Basis(problem, fitted)
        for k in periodic:
            step, spread = _pitch_step(problem, noise, fitted, history, k, basis)
            out[fitted.terms[k].name] = spread
            if moved or done == ROUNDS or not math.isfinite(spread.std) \
                    or abs(step) <= MOVED * spread.std:
                continue  # after a move the basis is the old fit's: the next round
            step = max(-MOST_STEPS * spread.std, min(MOST_STEPS * spread.std, step))
            better = _refitted(problem, noise, fitted, history, k, step, alpha)
            if better is not None:
                fitted, moved = better, True
        if not moved:
            break
    return fitted, out


class _Basis:
    """The final model's weighted columns, scaled, as an orthonormal basis with the
    SVD that made it: computed once per fit, shared by its periodic terms."""

    def __init__(self, problem: Problem, fitted: MapFit) -> None:
        xw = problem.weighted(fitted.jacobian.T).T
        self.scale = 1.0 / np.maximum(np.linalg.norm(xw, axis=0), 1e-300)
        u, s, vt = np.linalg.svd(xw * self.scale, full_matrices=False)
        keep = s > s[0] * RANK_TOLERANCE
        self.u, self.s, self.vt = u[:, keep], s[keep], vt[keep]


def _pitch_step(problem: Problem, noise: GaugeNoise, fitted: MapFit, history: JointHistory,
                k: int, basis: _Basis) -> tuple[float, ShapeSpread]:
    """The Gauss-Newton step of term ``k``'s pitch in the full model, its std and the
    path of the term's coefficients per mm of pitch along the profile."""
    term, coef = fitted.terms[k], fitted.coefficients[k]
    pitch = float(term.shape["pitch_mm"])
    h = pitch * RELATIVE_H
    up, down = (map_columns(problem, fitted.theta, [term.reshaped(pitch_mm=pitch + s)], history)
                for s in (h, -h))
    derivative = (up - down) @ coef / (2 * h)
    dw = problem.weighted(derivative[None])[0]
    u, s, vt, scale = basis.u, basis.s, basis.vt, basis.scale
    along = u.T @ dw
    apart = dw - u @ along
    information = float(apart @ apart)
    if information <= 0.0:
        return 0.0, ShapeSpread(math.inf)
    step = float(apart @ fitted.weighted_residuals) / information
    # the other parameters' least squares for the column: refitted as the pitch moves
    # by one mm they move by minus it (the term's own coefficients among them)
    regression = (vt.T @ (along / s)) * scale
    path = -regression[fitted.term_slice(k)]
    return step, ShapeSpread(math.sqrt(noise.variance / information), path)


def _refitted(problem: Problem, noise: GaugeNoise, fitted: MapFit, history: JointHistory,
              k: int, step: float, alpha: float) -> MapFit | None:
    """The full model refitted with term ``k``'s pitch moved by ``step`` (halved while
    the chi-square does not fall; None when it never does)."""
    pitch = float(fitted.terms[k].shape["pitch_mm"])
    for _ in range(3):
        terms = list(fitted.terms)
        terms[k] = terms[k].reshaped(pitch_mm=pitch + step)
        again = fit_with_maps(problem, noise, fitted.names, fitted.theta, terms, history,
                              alpha=alpha)
        if again.rss < fitted.rss:
            return again
        step /= 2
    return None
