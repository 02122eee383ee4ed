"""``screw_map``: a smooth error along the travel (the cumulative lead error of the
screw, its thermal growth pattern), a cubic spline in ``q``, its number of knots
chosen by the Bayesian information criterion."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ogacq.model.families.base import MapFamily, MapTerm, MapValue, SearchedAxis, ShapeGrid
from ogacq.model.gauges import AXES

# the inner knots tried: from a cubic over the range to one knot every few positions
KNOTS = (0, 1, 2, 3, 4, 6, 8, 12, 16, 24, 32)


@dataclass(frozen=True)
class SmoothShape:
    from_mm: float
    to_mm: float
    knots: int
    detrended: bool = False


def cubic_bspline(x: np.ndarray, knots: np.ndarray) -> np.ndarray:
    """(K, n) the cubic B-spline basis on the clamped knot vector (``knots`` the breaks
    from the first to the last, ascending) at ``x``, by the Cox-de Boor recursion
    (C. de Boor, A Practical Guide to Splines, 1978, ch. IX); values outside the
    breaks continue the end polynomials (a table holds its end values anyway)."""
    x = np.asarray(x, dtype=float)
    t = np.concatenate([[knots[0]] * 3, knots, [knots[-1]] * 3])
    # degree 0: the interval each x lies in, the last one closed, ends extended
    k0 = np.clip(np.searchsorted(knots, x, side="right") - 1, 0, len(knots) - 2) + 3
    basis = (np.arange(len(t) - 1)[:, None] == k0[None, :]).astype(float)
    for degree in range(1, 4):
        left_den = t[degree:-1] - t[:-degree - 1]
        right_den = t[degree + 1:] - t[1:-degree]
        with np.errstate(invalid="ignore", divide="ignore"):
            left = np.where(left_den[:, None] > 0,
                            (x[None, :] - t[:-degree - 1, None]) / left_den[:, None], 0.0)
            right = np.where(right_den[:, None] > 0,
                             (t[degree + 1:, None] - x[None, :]) / right_den[:, None], 0.0)
        basis = left * basis[:-1] + right * basis[1:]
    return basis


class Smooth(MapFamily[SmoothShape]):
    name = "screw_map"
    Shape = SmoothShape
    words = "smooth screw map"
    plausible_mm = 0.5
    pointwise = True

    def _knots(self, term: MapTerm) -> np.ndarray:
        s = self.params(term)
        return np.linspace(s.from_mm, s.to_mm, s.knots + 2)

    def shape_of(self, term: MapTerm, q: np.ndarray, side: np.ndarray, travel: np.ndarray,
                 t_s: np.ndarray) -> np.ndarray:
        ref = term.reference_mm
        knots = self._knots(term)
        at_ref = cubic_bspline(np.array([ref]), knots)
        # the basis sums to one: less one function it spans the rest once
        basis = (cubic_bspline(q, knots) - at_ref)[1:]
        if self.params(term).detrended:  # the slope is the encoder scale's
            grid = np.linspace(knots[0], knots[-1], 401) - ref
            on_grid = (cubic_bspline(grid + ref, knots) - at_ref)[1:]
            slope = on_grid @ grid / (grid @ grid)
            basis = basis - slope[:, None] * (q - ref)[None, :]
        return basis

    def size(self, term: MapTerm) -> int:
        return self.params(term).knots + 3

    def _over_range(self, term: MapTerm, points: int) -> tuple[np.ndarray, np.ndarray]:
        s = self.params(term)
        q = np.linspace(s.from_mm, s.to_mm, points)
        return q, term.shape_of(q, np.ones(len(q)), np.full(len(q), np.inf), np.zeros(len(q)))

    def size_mm(self, term: MapTerm, coefficients: np.ndarray) -> float:
        _, shape = self._over_range(term, 401)
        return float(np.max(np.abs(coefficients @ shape)))

    def value(self, term: MapTerm, coef: np.ndarray, cov: np.ndarray,
              shape_std: float) -> MapValue:
        """Its largest value over its range, where it is, with its std there."""
        s = self.params(term)
        q, g = self._over_range(term, 801)
        e = coef @ g
        k = int(np.argmax(np.abs(e)))
        std = float(math.sqrt(max(g[:, k] @ cov @ g[:, k], 0.0)))
        # the range as the term holds it: the JSON's form (an int stays one)
        return MapValue(float(e[k]), std, {
            "at_mm": round(float(q[k]), 3), "from_mm": term.shape["from_mm"],
            "to_mm": term.shape["to_mm"], "knots": s.knots,
            "slope_in_encoder_scale": s.detrended})

    def sentence(self, term: MapTerm, value: MapValue) -> str:
        return f"{self.words}, largest at {value.extra['at_mm']:+g} mm"

    def source(self, term: MapTerm) -> str:
        return f"smooth screw map (cubic spline, {self.params(term).knots} inner knots)"

    def in_place_of(self, term: MapTerm, effect: str) -> MapTerm:
        # in place of its axis's encoder scale, the map takes the slope too
        if effect == f"encoder_scale.{AXES[term.axis]}":
            return term.reshaped(detrended=0.0)
        return term

    def _term(self, axis: int, from_mm: float, to_mm: float, knots: int,
              fitted: tuple[str, ...]) -> MapTerm:
        # without its slope where the model has the axis's encoder scale
        detrend = f"encoder_scale.{AXES[axis]}" in fitted
        return MapTerm(self.name, axis, {"from_mm": from_mm, "to_mm": to_mm, "knots": knots,
                                         "detrended": float(detrend)})

    def swap_terms(self, axis: int, from_mm: float, to_mm: float,
                   fitted: tuple[str, ...]) -> list[MapTerm]:
        return [self._term(axis, from_mm, to_mm, 0, fitted)]  # a cubic

    def search(self, axis: SearchedAxis) -> list[ShapeGrid]:
        # more positions than the spline has functions, twice over
        choices = [k for k in KNOTS if k + 4 <= axis.positions // 2]
        if not choices:
            return []
        return [ShapeGrid(tuple(self._term(axis.axis, axis.from_mm, axis.to_mm, k, axis.fitted)
                                for k in choices), by_bic=True, of_q_alone=True)]
