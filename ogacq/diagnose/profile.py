"""Where along each axis the misfit sits: each leg's residuals as a profile along its
joint coordinate (per gauge the mean residual per bin, at most ``MAX_BINS``), before
(the joint-offset model) and after (the final model); the bins beyond the noise say
from where to where."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ogacq.diagnose.arrays import median, sorted_distinct
from ogacq.identify.observations import Observations
from ogacq.model.gauges import AXES, Gauge
from ogacq.model.units import UM_PER_MM

MAX_BINS = 200
MIN_POSITIONS = 10  # as the map search: fewer positions are postures, not a profile
SPARK = "▁▂▃▄▅▆▇█"
BEYOND_Z = 4.0


@dataclass(frozen=True)
class LegProfile:
    """One leg's residuals along its own joint coordinate: bin centres (mm), per gauge
    the mean residual per bin before and after (mm, NaN where a bin is empty), and the
    rms over the leg's gauges per bin."""

    leg: int
    q_mm: np.ndarray
    gauges: tuple[str, ...]
    before_mm: np.ndarray  # (gauges, bins)
    after_mm: np.ndarray
    rms_before_mm: np.ndarray  # (bins,) over every reading in the bin
    rms_after_mm: np.ndarray
    count: np.ndarray  # (bins,) readings

    def beyond(self, sigma_mm: float, after: bool = False) -> tuple[float, float] | None:
        """The span of bins whose rms exceeds the noise by more than chance would in
        any of them: ``BEYOND_Z`` standard errors of an rms of that many readings (a
        one-sided normal tail of 3e-5, 1 % over 300 bins): (from, to) mm."""
        rms = self.rms_after_mm if after else self.rms_before_mm
        limit = sigma_mm * (1.0 + BEYOND_Z / np.sqrt(2.0 * np.maximum(self.count, 1)))
        hot = np.flatnonzero(rms > limit)
        if not len(hot):
            return None
        return float(self.q_mm[hot[0]]), float(self.q_mm[hot[-1]])

    def spark(self, after: bool = False, width: int = 40, top: float | None = None) -> str:
        """The rms per bin as a line of ``width`` block characters, on the scale
        ``top`` (mm; the before profile's largest by default)."""
        rms = self.rms_after_mm if after else self.rms_before_mm
        edges = np.linspace(0, len(rms), min(width, len(rms)) + 1).astype(int)
        # a cell of bins none of which was read (a designed scan's sparse targets) blank
        cells = [np.sqrt(np.nanmean(rms[a:b] ** 2)) if np.isfinite(rms[a:b]).any()
                 else math.nan for a, b in zip(edges[:-1], edges[1:], strict=True)]
        scale = top if top is not None else float(np.nanmax(self.rms_before_mm))
        out = []
        for c in cells:
            if not math.isfinite(c):
                out.append(" ")
            else:
                level = int(np.clip(round(c / scale * (len(SPARK) - 1)), 0, len(SPARK) - 1)) \
                    if scale > 0 else 0
                out.append(SPARK[level])
        return "".join(out)

    def to_json(self) -> dict:
        def um(x: np.ndarray) -> list:
            return [None if not math.isfinite(v) else round(float(v) * UM_PER_MM, 3) for v in x]

        return {"leg": AXES[self.leg], "q_mm": [round(float(q), 4) for q in self.q_mm],
                "gauges": {g: {"before_um": um(self.before_mm[k]), "after_um": um(self.after_mm[k])}
                           for k, g in enumerate(self.gauges)},
                "rms_before_um": um(self.rms_before_mm), "rms_after_um": um(self.rms_after_mm),
                "readings": [int(c) for c in self.count]}


def leg_profiles(obs: Observations, before: np.ndarray, after: np.ndarray,
                 ) -> tuple[LegProfile, ...]:
    """Profiles of every leg read at enough positions (raw readings only)."""
    if not obs.raw:
        return ()
    lay = obs.layout
    out = []
    for leg in range(3):
        own = np.flatnonzero(lay.leg == leg)
        if not len(own):
            continue
        q = lay.q_mm[own, leg]
        positions = sorted_distinct(np.round(q, 6))
        if len(positions) < MIN_POSITIONS:
            continue
        lo, hi = float(positions[0]), float(positions[-1])
        step = median(np.diff(positions))
        bins = int(min(MAX_BINS, len(positions), max(1, round((hi - lo) / step) + 1)))
        width = (hi - lo) / max(bins - 1, 1)
        which = np.clip(np.round((q - lo) / width).astype(int), 0, bins - 1) if bins > 1 \
            else np.zeros(len(q), dtype=int)
        centres = lo + width * np.arange(bins)
        count = np.bincount(which, minlength=bins)
        keys = sorted({int(g) for g in lay.gauge_axis[own]})
        gauges = tuple(Gauge.at(j, leg).key for j in keys)
        per = {}
        for name, res in (("before", before), ("after", after)):
            r = res[own]
            means = np.full((len(keys), bins), np.nan)
            for k, j in enumerate(keys):
                sel = lay.gauge_axis[own] == j
                n = np.bincount(which[sel], minlength=bins)
                s = np.bincount(which[sel], weights=r[sel], minlength=bins)
                with np.errstate(invalid="ignore", divide="ignore"):
                    means[k] = np.where(n > 0, s / np.maximum(n, 1), np.nan)
            sq = np.bincount(which, weights=r**2, minlength=bins)
            with np.errstate(invalid="ignore", divide="ignore"):
                rms = np.where(count > 0, np.sqrt(sq / np.maximum(count, 1)), np.nan)
            per[name] = (means, rms)
        out.append(LegProfile(leg, centres, gauges, per["before"][0], per["after"][0],
                              per["before"][1], per["after"][1], count))
    return tuple(out)
