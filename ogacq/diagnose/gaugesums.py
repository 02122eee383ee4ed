"""The gauge zeros of raw readings removed, and their residuals weighted, with sums
per repeat group and per gauge instead of products by a (readings x gauges) one-hot.

On a long campaign that product is big enough for BLAS to split over threads, done
at every evaluation of every candidate: with the other cores busy the threads wait
for each other (72,000 readings, one core busy: 10-11 s per diagnosis against 5-7 s
on one thread). The same sums stay on the calling thread, equal up to the order of
the additions."""

from __future__ import annotations

import numpy as np

from ogacq.identify.fit import Weighting
from ogacq.identify.observations import Observations


class PerGauge:
    """Per-gauge sums along the last axis of arrays whose entries belong to the gauges
    ``gauge`` (n,), of ``n_gauges``."""

    def __init__(self, gauge: np.ndarray, n_gauges: int) -> None:
        self.gauge = gauge
        self._order = np.argsort(gauge, kind="stable")
        count = np.bincount(gauge, minlength=n_gauges)
        self._present = np.flatnonzero(count)  # a gauge may have lost all its readings
        self._starts = np.concatenate([[0], np.cumsum(count[self._present])[:-1]])
        self._n_gauges = n_gauges
        self._count = np.maximum(count, 1)

    def sums(self, x: np.ndarray) -> np.ndarray:
        """(..., G) the sum of each gauge's entries along the last axis."""
        out = np.zeros(x.shape[:-1] + (self._n_gauges,))
        out[..., self._present] = np.add.reduceat(x[..., self._order], self._starts, axis=-1)
        return out

    def project_out(self, x: np.ndarray, direction: np.ndarray,
                    norm2: np.ndarray) -> np.ndarray:
        """``x`` less its part along each gauge's ``direction`` (n,), of squared norm
        ``norm2`` (G,): a gauge's zero projected out, last axis."""
        return x - (self.sums(x * direction) / norm2)[..., self.gauge] * direction


class GaugeSums(PerGauge):
    """Per-gauge sums along the last axis of arrays over the readings of ``obs``."""

    def __init__(self, obs: Observations, weighting: Weighting) -> None:
        groups = weighting.groups
        assert groups is not None, "raw readings only"
        self._whiten = groups
        super().__init__(obs.layout.gauge, obs.layout.n_gauges)
        # A gauge's zero is constant over its readings, hence over each repeat group:
        # whitened (noise.GroupWhitener) it is each group's mean scale on its readings.
        self._zero = groups.mean_scale[groups.group]
        self._zero_norm = np.maximum(self.sums(self._zero**2), np.finfo(float).tiny)

    def remove_zeros(self, x: np.ndarray) -> np.ndarray:
        """``Observations.remove_zeros``: each gauge's mean taken out, last axis."""
        return x - (self.sums(x) / self._count)[..., self.gauge]

    def weighted(self, r: np.ndarray) -> np.ndarray:
        """``Weighting.residual`` of raw readings: whitened by the repeat groups'
        covariance, then the gauge zeros projected out there, last axis."""
        return self.project_out(self._whiten(r), self._zero, self._zero_norm)
