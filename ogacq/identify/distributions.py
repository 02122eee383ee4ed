"""Upper-tail probabilities of the chi-square, F and normal distributions.

The verdict needs three survival functions, but importing ``scipy.special`` costs a
command about 0.12 s of start-up (it pulls in numpy's f2py, masked arrays and the
array-API layer), a quarter of a 72-reading ``refit``. These are the textbook
continued fractions and series, vectorised over numpy arrays;
``tests/identify/test_distributions.py`` checks them against scipy to 1e-12
relative, tails and 10^6 degrees of freedom included.

Sources:
- the regularised incomplete gamma function by its series for x < a + 1 and
  Legendre's continued fraction otherwise, the regularised incomplete beta function
  by its continued fraction, each by the modified Lentz method: Press, Teukolsky,
  Vetterling, Flannery, *Numerical Recipes*, 3rd ed., 2007, sections 5.2, 6.2, 6.4;
- their factors x^a e^-x / Gamma(a) and x^a (1-x)^b / B(a, b) by the saddle-point
  form (the deviance ``bd0`` and Stirling's error ``stirlerr``), which keeps full
  precision where the logarithms of a large dof would cancel: C. Loader, "Fast and
  accurate computation of binomial probabilities", 2000;
- the chi-square and F tails as those functions: Abramowitz and Stegun 26.4.19 and
  26.6.2.
"""

from __future__ import annotations

import math

import numpy as np

EPS = 1e-15  # a series' or continued fraction's relative step at convergence
TINY = 1e-300  # keeps Lentz's denominators off zero
MAX_ITERATIONS = 100_000  # O(sqrt(a)) are needed: ample for any dof a campaign has
_LOG_2PI = math.log(2 * math.pi)
# Up to this many values, the series and fractions run one value at a time in Python
# floats: a verdict asks for one or a few, and a numpy call per iteration costs more
# than the arithmetic (0.45 ms a p-value at a few hundred dof; IEEE doubles give the
# same digits either way).
ONE_BY_ONE = 32

_lgamma = np.frompyfunc(math.lgamma, 1, 1)


def chi2_sf(dof: float | np.ndarray, x: float | np.ndarray) -> np.ndarray:
    """P(X > x) for X chi-square with ``dof`` degrees of freedom (1 for x <= 0)."""
    dof, x = np.broadcast_arrays(np.asarray(dof, float), np.asarray(x, float))
    return _gamma_q(dof / 2, np.maximum(x, 0.0) / 2)


def f_sf(dfn: float | np.ndarray, dfd: float | np.ndarray,
         f: float | np.ndarray) -> np.ndarray:
    """P(F > f) for F with (``dfn``, ``dfd``) degrees of freedom (1 for f <= 0)."""
    dfn, dfd, f = np.broadcast_arrays(np.asarray(dfn, float), np.asarray(dfd, float),
                                      np.asarray(f, float))
    f = np.maximum(f, 0.0)
    # x and 1 - x each from its own quotient: 1 - x would lose the digits of a tiny f
    with np.errstate(invalid="ignore", divide="ignore"):
        total = dfd + dfn * f
        x = np.where(np.isinf(f), 0.0, dfd / total)
        y = np.where(np.isinf(f), 1.0, dfn * f / total)
    return _beta_i(dfd / 2, dfn / 2, x, y)


def normal_sf(z: float | np.ndarray) -> np.ndarray:
    """P(Z > z) for a standard normal Z."""
    # erfc keeps the far tail, where 1 - Phi would lose every digit
    return np.vectorize(math.erfc, otypes=[float])(np.asarray(z, float) / math.sqrt(2.0)) / 2


def _stirling_error(a: np.ndarray) -> np.ndarray:
    """lgamma(a) - [(a - 1/2) ln a - a + ln(2 pi) / 2]: its asymptotic series above 15
    (five terms: error below 1e-17), the definition below."""
    out = np.empty(a.shape)
    large = a > 15
    n = a[large]
    nn = n * n
    out[large] = (1 / 12 - (1 / 360 - (1 / 1260 - (1 / 1680 - 1 / 1188 / nn) / nn) / nn)
                  / nn) / n
    small = a[~large]
    out[~large] = (_lgamma(small).astype(float) - (small - 0.5) * np.log(small) + small
                   - _LOG_2PI / 2)
    return out


def _deviance(a: np.ndarray, m: np.ndarray) -> np.ndarray:
    """a ln(a / m) + m - a, without the cancellation of its terms when m is near a."""
    out = a * np.log(a / m) + m - a
    near = np.abs(a - m) < 0.1 * (a + m)
    if near.any():
        an, mn = a[near], m[near]
        v = (an - mn) / (an + mn)
        total = (an - mn) * v
        term = 2 * an * v
        v2 = v * v
        for j in range(1, 1000):
            term = term * v2
            step = term / (2 * j + 1)
            total = total + step
            if np.all(np.abs(step) <= np.abs(total) * EPS):
                break
        out[near] = total
    return out


def _gamma_q(a: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The regularised upper incomplete gamma function Q(a, x), a > 0, x >= 0."""
    shape = np.shape(x)
    a, x = np.atleast_1d(a).astype(float), np.atleast_1d(x).astype(float)
    out = np.full(a.shape, np.nan)
    valid = (a > 0) & ~np.isnan(x)
    out[valid & (x == 0)] = 1.0
    out[valid & np.isinf(x)] = 0.0
    finite = valid & (x > 0) & np.isfinite(x)
    series = finite & (x < a + 1)
    fraction = finite & ~series
    if series.any():
        out[series] = 1.0 - _gamma_p_series(a[series], x[series])
    if fraction.any():
        out[fraction] = _gamma_q_fraction(a[fraction], x[fraction])
    return out.reshape(shape)


def _gamma_front(a: np.ndarray, x: np.ndarray) -> np.ndarray:
    """x^a e^-x / Gamma(a), in the saddle-point form."""
    return np.exp(-_deviance(a, x) - _stirling_error(a)) * np.sqrt(a / (2 * np.pi))


def _gamma_p_series(a: np.ndarray, x: np.ndarray) -> np.ndarray:
    """P(a, x) = x^a e^-x / Gamma(a) * sum x^n / (a (a+1) ... (a+n)), for x < a + 1."""
    if a.size <= ONE_BY_ONE:
        sums = [_series_sum(float(ai), float(xi)) for ai, xi in zip(a, x, strict=True)]
        return np.array(sums, dtype=float) * _gamma_front(a, x)
    term = 1.0 / a
    total = term.copy()
    ap = a.copy()
    live = np.ones(a.shape, bool)
    for _ in range(MAX_ITERATIONS):
        ap[live] += 1.0
        term[live] *= x[live] / ap[live]
        total[live] += term[live]
        live &= np.abs(term) >= np.abs(total) * EPS
        if not live.any():
            break
    return total * _gamma_front(a, x)


def _series_sum(a: float, x: float) -> float:
    """:func:`_gamma_p_series`'s sum for one (a, x), in Python floats: the same
    operations in the same order, so the same doubles."""
    term = 1.0 / a
    total = term
    ap = a
    for _ in range(MAX_ITERATIONS):
        ap += 1.0
        term *= x / ap
        total += term
        if not abs(term) >= abs(total) * EPS:
            break
    return total


def _gamma_q_fraction(a: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Q(a, x) by Legendre's continued fraction, for x >= a + 1 (modified Lentz)."""
    if a.size <= ONE_BY_ONE:
        fractions = [_gamma_fraction(float(ai), float(xi)) for ai, xi in zip(a, x, strict=True)]
        return _gamma_front(a, x) * np.array(fractions, dtype=float)
    b = x + 1.0 - a
    c = np.full(a.shape, 1.0 / TINY)
    d = 1.0 / b
    h = d.copy()
    live = np.ones(a.shape, bool)
    for i in range(1, MAX_ITERATIONS):
        idx = np.flatnonzero(live)
        an = -i * (i - a[idx])
        b[idx] += 2.0
        dl = _off_zero(an * d[idx] + b[idx])
        cl = _off_zero(b[idx] + an / c[idx])
        dl = 1.0 / dl
        delta = dl * cl
        d[idx], c[idx] = dl, cl
        h[idx] *= delta
        live[idx[np.abs(delta - 1.0) < EPS]] = False
        if not live.any():
            break
    return _gamma_front(a, x) * h


def _gamma_fraction(a: float, x: float) -> float:
    """:func:`_gamma_q_fraction`'s fraction for one (a, x), in Python floats: the same
    operations in the same order, so the same doubles."""
    b = x + 1.0 - a
    c = 1.0 / TINY
    d = 1.0 / b
    h = d
    for i in range(1, MAX_ITERATIONS):
        an = -i * (i - a)
        b += 2.0
        dl = _off_zero_1(an * d + b)
        cl = _off_zero_1(b + an / c)
        dl = 1.0 / dl
        delta = dl * cl
        d, c = dl, cl
        h *= delta
        if abs(delta - 1.0) < EPS:
            break
    return h


def _beta_i(a: np.ndarray, b: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The regularised incomplete beta function I_x(a, b), a, b > 0, 0 <= x <= 1,
    given y = 1 - x computed on its own."""
    shape = np.shape(x)
    a, b, x, y = (np.atleast_1d(v).astype(float) for v in (a, b, x, y))
    out = np.full(x.shape, np.nan)
    valid = (a > 0) & (b > 0) & (x >= 0) & (y >= 0)
    out[valid & (x == 0)] = 0.0
    out[valid & (y == 0)] = 1.0
    inner = valid & (x > 0) & (y > 0)
    # the fraction converges fast below the mean (a+1)/(a+b+2); above it, by symmetry
    direct = inner & (x < (a + 1) / (a + b + 2))
    mirrored = inner & ~direct
    if direct.any():
        i = direct
        out[i] = _beta_front(a[i], b[i], x[i], y[i]) * _beta_fraction(a[i], b[i], x[i]) / a[i]
    if mirrored.any():
        i = mirrored
        out[i] = 1.0 - (_beta_front(b[i], a[i], y[i], x[i])
                        * _beta_fraction(b[i], a[i], y[i]) / b[i])
    return out.reshape(shape)


def _beta_front(a: np.ndarray, b: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """x^a y^b / B(a, b), y = 1 - x, in the saddle-point form."""
    n = a + b
    log_front = (-_deviance(a, n * x) - _deviance(b, n * y)
                 + _stirling_error(n) - _stirling_error(a) - _stirling_error(b))
    return np.exp(log_front) * np.sqrt(a * b / (2 * np.pi * n))


def _beta_fraction(a: np.ndarray, b: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The continued fraction of I_x(a, b) (modified Lentz), for x < (a+1)/(a+b+2)."""
    if a.size <= ONE_BY_ONE:
        return np.array([_beta_fraction_1(float(ai), float(bi), float(xi))
                         for ai, bi, xi in zip(a, b, x, strict=True)], dtype=float)
    qab, qap, qam = a + b, a + 1.0, a - 1.0
    c = np.ones(a.shape)
    d = 1.0 / _off_zero(1.0 - qab * x / qap)
    h = d.copy()
    live = np.ones(a.shape, bool)
    for m in range(1, MAX_ITERATIONS):
        idx = np.flatnonzero(live)
        al, bl, xl = a[idx], b[idx], x[idx]
        m2 = 2 * m
        dl, cl, hl = d[idx], c[idx], h[idx]
        for aa in (m * (bl - m) * xl / ((qam[idx] + m2) * (al + m2)),  # the even step
                   -(al + m) * (qab[idx] + m) * xl / ((al + m2) * (qap[idx] + m2))):  # odd
            dl = 1.0 / _off_zero(1.0 + aa * dl)
            cl = _off_zero(1.0 + aa / cl)
            delta = dl * cl
            hl = hl * delta
        d[idx], c[idx], h[idx] = dl, cl, hl
        live[idx[np.abs(delta - 1.0) < EPS]] = False
        if not live.any():
            break
    return h


def _beta_fraction_1(a: float, b: float, x: float) -> float:
    """:func:`_beta_fraction` for one (a, b, x), in Python floats: the same
    operations in the same order, so the same doubles."""
    qab, qap, qam = a + b, a + 1.0, a - 1.0
    c = 1.0
    d = 1.0 / _off_zero_1(1.0 - qab * x / qap)
    h = d
    for m in range(1, MAX_ITERATIONS):
        m2 = 2 * m
        delta = 1.0
        for aa in (m * (b - m) * x / ((qam + m2) * (a + m2)),  # the even step
                   -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2))):  # the odd step
            d = 1.0 / _off_zero_1(1.0 + aa * d)
            c = _off_zero_1(1.0 + aa / c)
            delta = d * c
            h = h * delta
        if abs(delta - 1.0) < EPS:
            break
    return h


def _off_zero(v: np.ndarray) -> np.ndarray:
    return np.where(np.abs(v) < TINY, TINY, v)


def _off_zero_1(v: float) -> float:
    return TINY if abs(v) < TINY else v
