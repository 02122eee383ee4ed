"""Can these data tell the parameters apart? Rank, conditioning, correlations.

A parameter set is called identifiable when the design has full rank, no two
parameters are so correlated (|r| > 0.99) that the data only fix a combination
of them, and every parameter's std (propagated from the gauge noise) is within
its plausible range. Columns are scaled by each parameter's plausible range so
that mm, mrad and ppm compare fairly in the condition number.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cache

import numpy as np

from ogacq.model.parameters import effect_of

NAMED_CORRELATION = 0.95  # pairs above this are reported (INTERCHANGE.md)
INSEPARABLE_CORRELATION = 0.99  # above this, only a combination is determined
RANK_TOLERANCE = 1e-8


@dataclass
class Identifiability:
    """What the readings determine of the fitted parameters: rank, conditioning, the
    correlated pairs (INTERCHANGE.md), and why any are not identified."""

    names: tuple[str, ...]
    rank: int
    condition_number: float
    correlation: np.ndarray
    correlated_pairs: list[tuple[str, str, float]]
    identifiable: bool
    reasons: list[str] = field(default_factory=list)
    unidentified: list[str] = field(default_factory=list)


def assess(jw: np.ndarray, noise_cov: np.ndarray | None, names: Sequence[str],
           sigma_mm: float, *,
           scaled_svd: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
           ) -> tuple[Identifiability, np.ndarray]:
    """Identifiability of ``names`` from a weighted Jacobian (m, p), and the parameter
    covariance ``sigma^2 A C A'`` (eq. 12, ``A`` the pseudo-inverse) with infinite
    variance along directions the data do not see. ``scaled_svd``: the reduced SVD
    of ``jw`` with its columns scaled to the plausible ranges, when the caller has it."""
    names = tuple(names)
    p = len(names)
    ranges = plausible_ranges(names)
    u, s, vt = reduced_svd(jw * ranges) if scaled_svd is None else scaled_svd
    rank = rank_of(s)
    # plain floats: p is a handful, where a numpy call costs more than its arithmetic
    first, last = (float(s[0]), float(s[-1])) if p else (0.0, 0.0)
    # fewer rows than parameters: the smallest singular values are zeros it does not list
    cond = first / last if p and len(s) == p and last > first * RANK_TOLERANCE \
        else float("inf")

    # The estimator's covariance from the same scaled decomposition and the same rank
    # as the identifiability: an inverse of the unscaled Jacobian would cut its own
    # directions (mm beside ppm columns spread its singular values by 1e4 more), and a
    # direction inverted there but judged null here gave the identified parameters a
    # covariance made of rounding.
    a = _truncated_pinv(u, s, vt, rank) * ranges[:, None]
    cov = sigma_mm**2 * (a @ a.T if noise_cov is None else a @ noise_cov @ a.T)
    reasons: list[str] = []
    unidentified: set[str] = set()
    if rank < p:
        if vt.shape[0] < p:  # fewer rows than parameters: the reduced SVD lacks the rest
            vt = np.linalg.svd(jw * ranges, full_matrices=True)[2]
        # The projector onto the null space (in shares of each plausible range), not a
        # basis of it: a null space of several dimensions has any rotation of one basis
        # for another, and which one a BLAS kernel returns is its own affair.
        null = vt[rank:].T
        projector = null @ null.T
        weight = np.sqrt(np.maximum(projector.diagonal(), 0.0))
        loose = weight > 1e-3
        cov[loose, :] = np.nan
        cov[:, loose] = np.nan
        cov[loose, loose] = np.inf
        corr = projector / np.outer(np.maximum(weight, 1e-300), np.maximum(weight, 1e-300))
        corr[~np.outer(loose, loose)] = 0.0
        reasons.append(f"rank {rank} of {p}: the data fix only {rank} combinations of "
                       f"{', '.join(n for n, lo in zip(names, loose, strict=True) if lo)}")
        unidentified.update(n for n, lo in zip(names, loose, strict=True) if lo)
        finite = ~loose
        std = np.sqrt(np.diag(cov)[finite])
        sub = cov[np.ix_(finite, finite)] / np.outer(std, std)
        corr[np.ix_(finite, finite)] = sub
    else:
        std = np.sqrt(cov.diagonal())
        # np.outer's and np.fill_diagonal's own steps, without their generality
        corr = cov / (std[:, None] * std[None, :]) if (std > 0).all() else np.eye(p)
    corr.flat[::p + 1] = 1.0

    return _judged(names, rank, cond, corr, cov, reasons, unidentified), cov


def judge_covariance(names: Sequence[str], cov: np.ndarray) -> Identifiability:
    """The identifiability of ``names`` from a full-rank covariance a fit has computed
    otherwise (a diagnosis's final model with error maps beside the parameters: their
    joint covariance), by the same rules as :func:`assess`; the condition number is
    that of the design the covariance implies, columns scaled to the plausible ranges
    (the square root of the scaled covariance's eigenvalue ratio)."""
    names = tuple(names)
    ranges = plausible_ranges(names)
    eig = np.linalg.eigvalsh(cov / np.outer(ranges, ranges)) if len(names) else np.ones(1)
    condition_number = float(np.sqrt(eig[-1] / eig[0])) if eig[0] > 0 else float("inf")
    std = np.sqrt(np.maximum(cov.diagonal(), 0.0))
    p = len(names)
    corr = cov / (std[:, None] * std[None, :]) if (std > 0).all() else np.eye(p)
    corr.flat[::p + 1] = 1.0
    return _judged(names, p, condition_number, corr, cov, [], set())


def _judged(names: tuple[str, ...], rank: int, cond: float, corr: np.ndarray, cov: np.ndarray,
            reasons: list[str], unidentified: set[str]) -> Identifiability:
    """The pairs, the inseparable ones and the std beyond their ranges, said."""
    p = len(names)
    pairs = []
    rows = corr.tolist()  # the same doubles, read without numpy's scalar boxing
    for i in range(p):
        for j in range(i + 1, p):
            if abs(rows[i][j]) > NAMED_CORRELATION:
                pairs.append((names[i], names[j], rows[i][j]))
                if abs(rows[i][j]) > INSEPARABLE_CORRELATION:
                    unidentified.update((names[i], names[j]))
    # largest first as shown (4 decimals); pairs equal there keep the parameters' order,
    # not an order that the last bits of a BLAS kernel would choose
    pairs.sort(key=lambda t: -round(abs(t[2]), 4))
    strong = [f"{a}/{b} {c:+.4f}" for a, b, c in pairs if abs(c) > INSEPARABLE_CORRELATION]
    if strong and rank == p:
        reasons.append("only combinations are determined: correlation " + ", ".join(strong))
    if rank == p:
        ranges = plausible_ranges(names)
        for n, k_std, k_range in zip(names, np.sqrt(cov.diagonal()).tolist(), ranges.tolist(),
                                     strict=True):
            if k_std > k_range:
                reasons.append(f"{n} std {k_std:.3g} exceeds its plausible range "
                               f"{k_range:g} {effect_of(n).unit}")
                unidentified.add(n)
    return Identifiability(names, rank, cond, corr, pairs, not reasons, reasons,
                           [n for n in names if n in unidentified])


_SVD_REDUCED: np.ufunc | None
try:  # numpy's own gufunc behind np.linalg.svd (LAPACK gesdd), present in numpy 1.x and 2.x
    from numpy.linalg import _umath_linalg
    _SVD_REDUCED = _umath_linalg.svd_s
except (ImportError, AttributeError):  # pragma: no cover - a numpy that moved it
    _SVD_REDUCED = None


def reduced_svd(a: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``np.linalg.svd(a, full_matrices=False)`` for real (..., m, p) stacks: the same
    gufunc, so the same decomposition to the last bit, without the wrapper's type
    checks and promotion, which cost a refit's 72 x 3 matrices half as much again as
    the decomposition (a fit takes five). A decomposition that fails (NaN) is
    handed to ``np.linalg.svd`` to fail as it does (LinAlgError)."""
    if _SVD_REDUCED is None or a.dtype != np.float64 or a.ndim < 2:
        return np.linalg.svd(a, full_matrices=False)
    with np.errstate(all="ignore"):  # as np.linalg.svd's, whose invalid flag means failure
        u, s, vt = _SVD_REDUCED(a, signature="d->ddd")
    if np.isnan(s).any():
        return np.linalg.svd(a, full_matrices=False)
    return u, s, vt


def rank_of(s: np.ndarray) -> int:
    """Rank from the singular values (p,) of a Jacobian scaled to plausible ranges."""
    values = s.tolist()
    if not values or values[0] <= 0:
        return 0
    floor = values[0] * RANK_TOLERANCE
    return sum(v > floor for v in values)


@cache
def _ranges_of(names: tuple[str, ...]) -> np.ndarray:
    ranges = np.array([effect_of(n).plausible_range for n in names], dtype=float)
    ranges.setflags(write=False)  # shared by every caller
    return ranges


def plausible_ranges(names: Sequence[str]) -> np.ndarray:
    """(p,) each parameter's plausible range (read-only; built once per set)."""
    return _ranges_of(tuple(names))


def _truncated_pinv(u: np.ndarray, s: np.ndarray, vt: np.ndarray, rank: int) -> np.ndarray:
    """The pseudo-inverse (p, m) of the matrix whose reduced SVD is ``u s vt``, inverted
    along its ``rank`` largest directions only."""
    if rank == 0:
        return np.zeros((vt.shape[1], u.shape[0]))
    return vt[:rank].T @ ((1 / s[:rank])[:, None] * u[:, :rank].T)
