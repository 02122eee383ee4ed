"""Which other effects explain these data equally well?

Each effect of the chosen model is swapped for every other effect of the library
and refitted; a swap worse by less than ``SWAP_CHI2`` (in noise variances, inflated
by the misfit left) is an alternative. The threshold is a three-sigma rule: were the
alternative true, its fit would come out worse by more than 9 only with noise 3 std
along their difference (< 0.14 %), so the truth is the effect or among its
alternatives."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ogacq.diagnose.batchfit import Problem, fit_many
from ogacq.diagnose.library import BASE_MODEL, singles
from ogacq.diagnose.selection import Model
from ogacq.identify.noise import GaugeNoise
from ogacq.identify.search_rules import SWAP_CHI2
from ogacq.model.parameters import NOMINAL, PARAM_INDEX, indices


@dataclass(frozen=True)
class Alternative:
    name: str
    value: float  # its value when it takes the effect's place
    delta_chi2: float  # how much worse than the chosen effect it fits
    theta: np.ndarray  # the swapped model's full parameter vector


def noise_scale(model: Model) -> float:
    """Variance inflation when the model is not within the noise (Birge ratio^2):
    what is left unexplained blurs the comparison as much as noise would."""
    chi2_dof = model.verdict.chi2_dof
    return max(1.0, chi2_dof) if np.isfinite(chi2_dof) else 1.0


def alternatives(problem: Problem, noise: GaugeNoise,
                 model: Model) -> dict[str, list[Alternative]]:
    """For each effect of ``model``, the library effects that could take its place."""
    scale = noise.variance * noise_scale(model)
    out: dict[str, list[Alternative]] = {}
    pool = singles(model.effects)
    for name in model.effects:
        others = tuple(e for e in model.effects if e != name)
        start = model.theta.copy()
        start[PARAM_INDEX[name]] = NOMINAL[PARAM_INDEX[name]]
        cands = fit_many(problem, start, BASE_MODEL + others, pool)
        delta = (cands.rss - model.rss) / scale
        ok = cands.full_rank() & cands.plausible() & (delta < SWAP_CHI2)
        found = [Alternative(pool[k][0], float(cands.theta[k, indices(pool[k])][0]),
                             float(delta[k]), cands.theta[k])
                 for k in np.flatnonzero(ok)]
        out[name] = sorted(found, key=lambda a: a.delta_chi2)
    return out
