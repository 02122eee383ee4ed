"""Does a bigger model fit significantly better than a smaller one nested in it?
The nested-model tests and information criteria of the effect selection, judged
against the same gauge noise as the verdict (``ogacq/identify/consistency.py``)."""

from __future__ import annotations

import math
from typing import TypeVar

import numpy as np

from ogacq.identify.distributions import chi2_sf, f_sf
from ogacq.identify.noise import GaugeNoise

#: a float, or an array of candidates' values
ArrayOrFloat = TypeVar("ArrayOrFloat", float, np.ndarray)


def nested_test(rss_small: float, rss_big: float, added: int, dof_big: int,
                noise: GaugeNoise) -> tuple[float, float]:
    """Does the bigger of two nested models fit significantly better? Returns (F, p).

    The improvement per added parameter is compared with the larger of the gauge
    noise and what the bigger model leaves unexplained: the likelihood-ratio test
    when that model is within the noise, else the classical F-test, so that a
    partial fit of an unknown error is not mistaken for the effect."""
    f_stat, p = nested_tests(rss_small, np.array([rss_big]), np.array([added]),
                             np.array([dof_big]), noise)
    return float(f_stat[0]), float(p[0])


def nested_tests(rss_small: float, rss_big: np.ndarray, added: np.ndarray,
                 dof_big: np.ndarray, noise: GaugeNoise) -> tuple[np.ndarray, np.ndarray]:
    """:func:`nested_test` for many bigger models at once (arrays of equal length)."""
    rss_big = np.asarray(rss_big, dtype=float)
    added = np.asarray(added)
    dof_big = np.asarray(dof_big)
    valid = (added > 0) & (dof_big > 0)
    k, dof = np.maximum(added, 1), np.maximum(dof_big, 1)
    gain = np.maximum(rss_small - rss_big, 0.0) / k
    misfit = rss_big / dof
    by_misfit = misfit > noise.variance
    f_stat = np.where(by_misfit, gain / np.where(by_misfit, misfit, 1.0), gain / noise.variance)
    # each tail only where it is taken: they are series and fractions per value, and a
    # selection step tests hundreds of candidates
    k, dof, f_stat, by_misfit = np.broadcast_arrays(k, dof, f_stat, by_misfit)
    p = np.empty(f_stat.shape)
    p[by_misfit] = f_sf(k[by_misfit], dof[by_misfit], f_stat[by_misfit])
    by_noise = ~by_misfit
    k_n, f_n = k[by_noise], f_stat[by_noise]
    p[by_noise] = (f_sf(k_n, noise.dof, f_n) if noise.measured and noise.dof is not None
                   else chi2_sf(k_n, f_n * k_n))
    return np.where(valid, f_stat, 0.0), np.where(valid, p, 1.0)


def bic_change(rss_drop: ArrayOrFloat, added_params: ArrayOrFloat, n_data: int,
               noise: GaugeNoise) -> ArrayOrFloat:
    """The Bayesian information criterion's change (G. Schwarz, Ann. Stat. 6, 1978)
    when a model with ``added_params`` more parameters lowers the residual sum of
    squares by ``rss_drop``, the noise taken as known: negative when the bigger model
    pays for its parameters. Element-wise for arrays of candidates. The one place the
    BIC is computed: the effect selection and the map search judge by it alike."""
    return -rss_drop / noise.variance + added_params * math.log(max(n_data, 2))

