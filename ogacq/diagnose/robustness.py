"""Does a claim rest on one cell (one gauge at one posture)?

A stand knocked between two readings puts all its misfit in one cell, and with
hundreds of candidate pairs some pair absorbs it. So the cell that gains most from
the claimed effects is left out and both models refitted without it: if the effects
are then not significant (corrected as when chosen), a disturbance there is named
as an equally good explanation."""

from __future__ import annotations

from math import comb

import numpy as np

from ogacq.diagnose.batchfit import Problem, fit_many
from ogacq.diagnose.library import BASE_MODEL, EFFECT_PARAMETERS
from ogacq.diagnose.locate import RowLabels
from ogacq.diagnose.nested import nested_test
from ogacq.diagnose.selection import Model
from ogacq.identify.consistency import LEVEL
from ogacq.identify.noise import GaugeNoise
from ogacq.model.parameters import NOMINAL, indices


def _cells(labels: RowLabels) -> tuple[list[str], np.ndarray]:
    """The cells read ("y_x at max"), in order of their first reading, and each
    reading's cell (index into them)."""
    _, first, cell = np.unique(labels.cell_codes(), return_index=True, return_inverse=True)
    order = np.argsort(first)
    rank = np.empty(len(order), dtype=int)
    rank[order] = np.arange(len(order))
    gauges, postures = labels.gauge, labels.posture.astype(str)
    return ([f"{gauges[k]} at {postures[k]}" for k in first[order].tolist()],
            rank[cell.ravel()])


def resting_cell(problem: Problem, noise: GaugeNoise, base: Model, claimed: Model,
                 alpha: float = LEVEL) -> str | None:
    """The cell (``"y_x at max"``) without which the claimed effects lose their
    significance, or None when they stand without any single cell."""
    if not claimed.effects:
        return None
    obs = problem.obs
    names, cells = _cells(problem.labels)
    gain = (base.residuals**2 - claimed.residuals**2) / (
        np.ones(len(obs)) if obs.raw else np.diag(obs.noise_cov))
    top = max(range(len(names)), key=lambda c: gain[cells == c].sum())
    keep = cells != top
    rest = Problem(obs.kept(keep), noise)
    if rest.n_data <= len(claimed.names):
        return names[top]
    start = claimed.theta.copy()
    start[indices(claimed.effects)] = NOMINAL[indices(claimed.effects)]
    offsets = fit_many(rest, start, BASE_MODEL, [()])
    effects = fit_many(rest, claimed.theta, BASE_MODEL, [claimed.effects])
    dof = rest.n_data - int(effects.rank[0])
    _, p = nested_test(float(offsets.rss[0]), float(effects.rss[0]),
                       int(effects.rank[0] - offsets.rank[0]), dof, noise)
    searched = comb(len(EFFECT_PARAMETERS), len(claimed.effects))
    return names[top] if p * searched >= alpha else None
