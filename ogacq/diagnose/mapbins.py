"""The periodogram's inner products summed over binned positions, not over readings.

A cyclic candidate's column at a repeat group ``g`` is ``T(q_g) s_g + T(Q_g) S_g``
(a trial function of the joint coordinate at the reading and at its gauge's
setting, times the sensitivities there), so every quantity the gain needs
(``mapspace._gains``) is a sum over positions of ``T`` times weights independent of
the trial frequency:

    c.v      = sum_n T(n) W_v(n)
    c_k.c_l  = sum_n T_k T_l D(n) + sum_(n, j) X(n, j) (T_k(n) T_l(j) + T_l(n) T_k(j))
               - sum_gauge (sum_n T_k(n) A(gauge, n)) (sum_n T_l(n) A(gauge, n)) / |zero|^2

(``n`` the positions' nodes, ``j`` the settings'). The weights are summed once;
each frequency then costs the nodes, not the readings. Positions within a bin are
one node at their mean: at ``1 / BINS_PER_PITCH`` of the shortest pitch the gain
drops by under 0.2 % (the sinc of the phase's spread), and the candidate taken is
tested on the exact columns. Positions no more than the bins are exact."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from ogacq.diagnose.mapspace import Gain, MapSpace, _gains
from ogacq.identify.search_rules import OVERSAMPLE

# Bins per period of the shortest pitch searched: half a bin is 1/64 of a period,
# a phase error of at most 5.6 degrees (no source: a choice, its effect above).
BINS_PER_PITCH = 32

# (F,) frequencies, (N,) positions -> (F, k, N) the candidate's shape functions
TrialFunctions = Callable[[np.ndarray, np.ndarray], np.ndarray]


class PositionSums:
    """The frequency-free weights of one axis's cyclic candidates in ``space``."""

    def __init__(self, space: MapSpace, q_rep: np.ndarray, q_set: np.ndarray,
                 s_rep: np.ndarray, s_set: np.ndarray, bin_mm: float) -> None:
        gauge, m, zn = space._gauge_of_group, space._mean_dir, space._zero_norm2
        node_r, positions_r = _bins(q_rep, bin_mm)
        settings, node_s = np.unique(np.round(q_set, 9), return_inverse=True)
        n_r = len(positions_r)
        node_s = node_s + n_r
        self.positions = np.concatenate([positions_r, settings])
        self.settings = np.arange(n_r, n_r + len(settings))
        n = len(self.positions)

        def by_node(weights_r: np.ndarray, weights_s: np.ndarray) -> np.ndarray:
            """(..., N) per-group weights of the reading's and the setting's terms
            summed at their nodes."""
            flat_r = np.atleast_2d(weights_r)
            flat_s = np.atleast_2d(weights_s)
            return np.stack([np.bincount(node_r, weights=wr, minlength=n)
                             + np.bincount(node_s, weights=ws, minlength=n)
                             for wr, ws in zip(flat_r, flat_s, strict=True)])

        # c.v for v in the residual and the model's directions: u_g = m v - m^2 beta / |zero|^2
        vectors = np.vstack([space.r_groups[None], space.basis_groups])  # (1 + p, G)
        beta = np.stack([np.bincount(gauge, weights=m * v, minlength=len(zn))
                         for v in vectors])
        u = m * vectors - m**2 * (beta / zn)[:, gauge]
        self.w = by_node(s_rep * u, s_set * u)  # (1 + p, N)
        m2 = m**2
        self.d = by_node(m2 * s_rep**2, m2 * s_set**2)[0]  # (N,)
        # the reading's node with its setting's: (N, J)
        j = node_s - n_r
        self.x = np.zeros((n, len(settings)))
        np.add.at(self.x, (node_r, j), m2 * s_rep * s_set)
        # each gauge's zero: (gauges, N) its sums, and its squared norm
        present = np.flatnonzero(np.bincount(gauge, minlength=len(zn)))
        rows = np.searchsorted(present, gauge)
        self.a = np.zeros((len(present), n))
        np.add.at(self.a, (rows, node_r), m2 * s_rep)
        np.add.at(self.a, (rows, node_s), m2 * s_set)
        self.zero_norm2 = zn[present]

    def gain(self, freqs: np.ndarray, functions: TrialFunctions) -> Gain:
        """Gains of the candidates whose shapes are ``functions(freqs, positions)``."""
        t = functions(freqs, self.positions)  # (F, k, N)
        n_f, k, n = t.shape
        # the sums over the positions as matrix products (one BLAS call each, where
        # einsum's own loops cost several times more on thousands of positions)
        flat = t.reshape(n_f * k, n)
        cv = (flat @ self.w.T).reshape(n_f, k, -1)
        cr, cb = cv[:, :, 0], cv[:, :, 1:]
        cc = (t * self.d) @ t.transpose(0, 2, 1)
        y = (flat @ self.x).reshape(n_f, k, -1)
        t_set = t[:, :, self.settings]
        cross = y @ t_set.transpose(0, 2, 1)
        cc += cross + cross.transpose(0, 2, 1)
        z = (flat @ self.a.T).reshape(n_f, k, -1)
        cc -= (z / self.zero_norm2) @ z.transpose(0, 2, 1)
        return _gains(cc, cb, cr)


# The spectral window's height (of its main lobe's 1) at which positions no longer
# tell a frequency from one shifted by that much: half its power (no source: a choice;
# uniform positions reach 1 at the reciprocal of their step).
ALIAS_WINDOW = 0.5


def phasors(first: float, step: float, count: int, q: np.ndarray) -> np.ndarray:
    """(count, len(q)) ``exp(2 pi i f q)`` at ``count`` frequencies ``f`` from ``first``
    every ``step``, each next one's the last one's times one step's: a complex product
    where a sine and a cosine cost ten times more (exact at ``first``, within a few
    hundred roundings at the last)."""
    phase = 2j * np.pi * q
    terms = np.empty((count, len(q)), dtype=complex)
    terms[0] = np.exp(phase * first)
    terms[1:] = np.exp(phase * step)
    return np.cumprod(terms, axis=0)


def alias_pitch_mm(positions: np.ndarray, highest_mm: float) -> float:
    """The shortest period that distinct ``positions`` cannot tell from a constant:
    1 / the lowest frequency past the main lobe where their spectral window
    ``|sum exp(2 pi i f q)|^2 / K^2`` reaches ``ALIAS_WINDOW`` (the window function of
    irregular sampling, J. T. VanderPlas, ApJS 236, 2018: its peaks are where a
    sinusoid's power is aliased). Uniform positions: their step, exactly. None found
    up to the frequency of ``highest_mm``: that period. A cyclic error is then
    resolved only below half of that frequency, where no alias of another in the band
    falls (``AxisCoverage.pitch_band_mm`` keeps 2.5 a period, a margin over 2)."""
    q = np.sort(np.asarray(positions, dtype=float))
    gaps = np.diff(q)
    if len(gaps) == 0:
        return math.inf
    if np.allclose(gaps, gaps[0], rtol=0.0, atol=2e-6):  # to the positions' rounding
        return float(gaps[0])
    span = float(q[-1] - q[0])
    df = 1.0 / (OVERSAMPLE * span)
    freqs = np.arange(2.0 / span, 1.0 / highest_mm + df / 2, df)
    for lo in range(0, len(freqs), 64):
        f = freqs[lo:lo + 64]
        window = np.abs(phasors(f[0], df, len(f), q - q[0]).mean(axis=1)) ** 2
        hit = np.flatnonzero(window >= ALIAS_WINDOW)
        if len(hit):
            return 1.0 / float(f[hit[0]])
    return highest_mm


def _bins(q: np.ndarray, width_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """Each position's node and every node's position: the distinct positions (to a
    nanometre) where they are no more than bins of ``width_mm`` over their range
    would be (then exact), else those bins at their mean positions."""
    distinct, node = np.unique(np.round(q, 9), return_inverse=True)
    if len(distinct) <= float(np.ptp(q)) / width_mm + 1:
        return node.reshape(-1), distinct
    key = np.floor(q / width_mm).astype(np.int64)
    _, node, counts = np.unique(key, return_inverse=True, return_counts=True)
    node = node.reshape(-1)
    return node, np.bincount(node, weights=q) / counts
