"""The map search's decision, and the size of an error it finds reliably.

The search (``ogacq.diagnose.mapsearch``) takes a cyclic error when its nested test's
p, times the pitches it tried and the candidates beside it, is under the level
(``LEVEL``), when it pays for its parameters (BIC), and when no peak of the
periodogram apart from its own main lobe comes within ``SWAP_CHI2`` of it. A design
that states what its scan detects must state it for that decision, not for a test at
a known pitch: the minimum detectable value of ISO 11843-1:1997 (3.2.4), the true
size found with probability ``FOUND_SHARE`` (1 - beta) under the decision rule. Found
on the built-in machine's designed scan over 100 simulated seeds: errors of 3 times
the amplitude's std at a known pitch (0.76 µm at 0.5 µm noise) were taken in 3 of 10
cases, most of them said unresolved between rival peaks; from about 3 µm in all.

Two conditions, each with its own noncentrality (the error's chi-square beside the
noise, ``lambda = (A / sigma_A)^2`` for a cyclic error of amplitude A whose
amplitude's std is sigma_A):

- the test: the gain, a noncentral chi-square of ``dof`` degrees of freedom, beyond
  the threshold the corrected level and the BIC set, with probability FOUND_SHARE
  (Patnaik's approximation of the noncentral chi-square by a scaled central one,
  Biometrika 36 (1949) 202);
- the rival rule: the gain at the true pitch less the gain at the strongest sidelobe
  (which captures a share ``rho^2`` of the error), about ``lambda (1 - rho^2)`` with a
  standard deviation of about ``2 sqrt(lambda (1 - rho^2))`` (the noise's part linear
  in the signal), beyond SWAP_CHI2 with probability FOUND_SHARE: ``lambda (1 - rho^2)
  >= (z + sqrt(z^2 + SWAP_CHI2))^2``. No source: the project's approximation, checked
  by ``bench/table_coverage.py``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from statistics import NormalDist

import numpy as np

from ogacq.identify.consistency import LEVEL
from ogacq.identify.distributions import chi2_sf

__all__ = ["FOUND_SHARE", "LEVEL", "OVERSAMPLE", "SHORTEST_LEAD_MM", "SWAP_CHI2",
           "chi2_threshold", "found_noncentrality", "local_maxima", "resolved_noncentrality"]

# The swap test's three-sigma rule: a model that fits within this chi-square of
# another is not preferred to it (alternatives, rival pitches).
SWAP_CHI2 = 9.0
OVERSAMPLE = 5  # the periodogram's grid: this many pitches per resolution element
# The shortest cyclic error searched for: the shortest lead of the ball screws that
# drive machine axes (ISO 3408-2's nominal leads, as makers' catalogues list them,
# start at 1 mm, e.g. THK's miniature BNK0401). A denser scan is not searched at
# shorter pitches it could resolve: none is physics this model has.
SHORTEST_LEAD_MM = 1.0
FOUND_SHARE = 0.95  # 1 - beta of a stated detection limit (ISO 11843-1's beta = 0.05)


def _bracket(short: Callable[[float], bool], hi: float) -> tuple[float, float]:
    """Where ``short`` turns false, to 1e-9: ``hi`` doubled until past it, then bisected."""
    lo = 0.0
    while short(hi):
        hi *= 2.0
    for _ in range(200):
        mid = (lo + hi) / 2.0
        lo, hi = (mid, hi) if short(mid) else (lo, mid)
        if hi - lo < 1e-9 * hi:
            break
    return lo, hi


def chi2_threshold(dof: float, p: float) -> float:
    """x with P(chi-square of ``dof`` > x) = ``p`` (bisection on the survival function)."""
    lo, hi = _bracket(lambda x: float(chi2_sf(dof, x)) > p, max(4.0 * dof, 10.0))
    return (lo + hi) / 2.0


def noncentral_chi2_sf(dof: float, noncentrality: float, x: float) -> float:
    """P(X > x) for X noncentral chi-square (Patnaik: c chi-square of nu)."""
    c = (dof + 2.0 * noncentrality) / (dof + noncentrality)
    nu = (dof + noncentrality) ** 2 / (dof + 2.0 * noncentrality)
    return float(chi2_sf(nu, x / c))


def found_noncentrality(dof: float, threshold: float, share: float = FOUND_SHARE) -> float:
    """The noncentrality whose gain passes ``threshold`` with probability ``share``."""
    return _bracket(lambda lam: noncentral_chi2_sf(dof, lam, threshold) < share,
                    threshold + 10.0)[1]


def resolved_noncentrality(sidelobe_share: float, share: float = FOUND_SHARE) -> float:
    """The noncentrality whose gain stays SWAP_CHI2 above a sidelobe that captures
    ``sidelobe_share`` of the error, with probability ``share`` (inf: a sidelobe that
    captures it all)."""
    if sidelobe_share >= 1.0:
        return math.inf
    z = NormalDist().inv_cdf(share)
    return (z + math.sqrt(z * z + SWAP_CHI2)) ** 2 / (1.0 - sidelobe_share)


def local_maxima(values: np.ndarray) -> np.ndarray:
    """The indices of a periodogram's peaks: each value at least its neighbours, an end
    above its one neighbour (at least three values: fewer hold no peak apart from
    another's lobe, and the callers say so)."""
    inner = (values[1:-1] >= values[:-2]) & (values[1:-1] >= values[2:])
    return np.flatnonzero(np.concatenate([[values[0] > values[1]], inner,
                                          [values[-1] > values[-2]]]))
