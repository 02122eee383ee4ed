"""The verdict's own tail probabilities against scipy.special, an independent
implementation (Cephes), over the degrees of freedom and tails a campaign reaches."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import special

from ogacq.identify.distributions import ONE_BY_ONE, chi2_sf, f_sf, normal_sf

P_LEVELS = [1e-300, 1e-100, 1e-12, 1e-6, 1e-3, 0.01, 0.1, 0.3, 0.5, 0.7, 0.9, 0.999999]


@pytest.mark.parametrize("dof", [1, 2, 3, 4.5, 11, 49, 100, 1000, 35_000, 70_000])
def test_chi2_tail_matches_scipy(dof: float) -> None:
    x = special.chdtri(dof, P_LEVELS)
    ours, theirs = chi2_sf(dof, x), special.chdtrc(dof, x)
    np.testing.assert_allclose(ours, theirs, rtol=2e-12, atol=0)


@pytest.mark.parametrize("dfn", [1, 2, 3, 5.5, 11, 50, 1000])
@pytest.mark.parametrize("dfd", [1, 2, 4, 7.3, 49, 500, 35_000, 100_000])
def test_f_tail_matches_scipy(dfn: float, dfd: float) -> None:
    levels = [q for q in P_LEVELS if q > 1e-15]  # fdtri's own reach
    f = special.fdtri(dfn, dfd, 1 - np.array(levels))
    f = f[np.isfinite(f) & (f > 0)]
    ours, theirs = f_sf(dfn, dfd, f), special.fdtrc(dfn, dfd, f)
    small = theirs < 0.5  # relative where small; near 1 Cephes itself errs by ~1e-11
    np.testing.assert_allclose(ours[small], theirs[small], rtol=5e-12, atol=0)
    np.testing.assert_allclose(ours[~small], theirs[~small], rtol=0, atol=2e-11)


def test_closed_forms() -> None:
    # chi-square with 2 dof: e^(-x/2); F(1, 1): 1 - (2/pi) atan(sqrt f); F(2, 2): 1/(1 + f)
    x = np.array([1e-12, 1e-3, 0.5, 3.0, 40.0, 1000.0])
    np.testing.assert_allclose(chi2_sf(2, x), np.exp(-x / 2), rtol=1e-14)
    np.testing.assert_allclose(f_sf(1, 1, x), 1 - 2 / np.pi * np.arctan(np.sqrt(x)), rtol=1e-13)
    np.testing.assert_allclose(f_sf(2, 2, x), 1 / (1 + x), rtol=1e-13)


def test_far_f_tail_keeps_its_digits() -> None:
    # a misfit hundreds of noise variances big: p far below what 1 - cdf could hold
    f = np.array([50.0, 200.0, 1000.0])
    np.testing.assert_allclose(f_sf(3, 49, f), special.fdtrc(3, 49, f), rtol=1e-12)
    assert f_sf(3, 49, 1000.0) < 1e-40


def test_normal_tail_matches_scipy() -> None:
    z = np.linspace(-8, 37, 200)
    np.testing.assert_allclose(normal_sf(z), special.ndtr(-z), rtol=1e-12)


def test_vectorised_over_cells_with_their_own_dof() -> None:
    rng = np.random.default_rng(3)
    dof = rng.integers(1, 40, 2000).astype(float)
    x = rng.uniform(0, 150, 2000)
    np.testing.assert_allclose(chi2_sf(dof, x), special.chdtrc(dof, x), rtol=1e-12)
    np.testing.assert_allclose(f_sf(dof, 49.3, x / dof), special.fdtrc(dof, 49.3, x / dof),
                               rtol=1e-12)


def test_edges() -> None:
    np.testing.assert_array_equal(chi2_sf(3, [0.0, -1.0, np.inf]), [1.0, 1.0, 0.0])
    np.testing.assert_array_equal(f_sf(3, 4, [0.0, -1.0, np.inf]), [1.0, 1.0, 0.0])
    assert np.isnan(chi2_sf(3, np.nan)) and np.isnan(f_sf(3, 4, np.nan))
    assert np.isnan(chi2_sf(0, 1.0))  # no degrees of freedom: no distribution
    assert np.shape(chi2_sf(3, 2.0)) == () and np.shape(f_sf(3, 4, [1.0, 2.0])) == (2,)


def test_one_value_at_a_time_gives_the_same_doubles() -> None:
    # a few values run in Python floats, many in numpy arrays: the same operations in
    # the same order, so each p-value must come out bit for bit the same either way
    dof = np.array([1, 2, 3, 4.5, 11, 49, 100, 1000, 35_000, 70_000] * 2, dtype=float)
    x = np.concatenate([dof * 0.3, dof * 1.7])  # the series and the fraction
    dof = np.concatenate([dof, dof])
    many = chi2_sf(dof, x)
    assert len(many) > ONE_BY_ONE  # the numpy path
    np.testing.assert_array_equal(
        many, [float(chi2_sf(d, v)) for d, v in zip(dof, x, strict=True)])
    dfd = np.full(len(x), 49.0)
    many_f = f_sf(dof, dfd, x / dof)
    np.testing.assert_array_equal(many_f, [float(f_sf(d, 49.0, v / d))
                                           for d, v in zip(dof, x, strict=True)])
