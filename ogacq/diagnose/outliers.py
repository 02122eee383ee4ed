"""Single readings that disagree with their repeats: a mis-read dial, a value typed
wrong, a gauge knocked and set back between two cycles.

Model-free, so that no missing physics can pass for one: a posture's repeats read
one machine state. A reading is named when it lies far from its repeats while those
agree among themselves (an effect that changes from cycle to cycle moves them apart
as well, and is left to the diagnosis). The repeats are fitted with their group's
mean and a slope in time per gauge (a warm-up moves every posture's later cycles
alike), each reading judged by its externally studentized residual (Cook and
Weisberg, "Residuals and Influence in Regression", 1982, 2.2: residual over
``sigma sqrt(1 - h)``), ``sigma`` the stated noise or else the pooled scatter of
every other reading; its p multiplied by the readings tested (Bonferroni)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ogacq.diagnose.locate import RowLabels, row_labels
from ogacq.identify.consistency import LEVEL, Verdict, fit_verdict, format_p
from ogacq.identify.distributions import chi2_sf, f_sf, normal_sf
from ogacq.identify.fit import FitResult, fit
from ogacq.identify.noise import GaugeNoise, noise_for
from ogacq.identify.observations import Observations
from ogacq.model.units import UM_PER_MM

# The repeats left must agree at this level, or the group moved as a whole (a drift,
# an effect of the cycle) and no one reading of it is to blame; well above the test's
# own level, so that a drift of a few noise steps per cycle is not named a slip.
OTHERS_AGREE_LEVEL = 0.1
# Named in at most this share of the repeat groups: beyond it the disagreement is
# the campaign's, not a few readings'.
MOST_GROUPS_SHARE = 0.25
# A display's rounding error lies within half a step either way, so its variance about
# the true value is at most step^2 / 4 (two levels half a step off, equally often: a
# machine resting at a division's edge). Repeats of a coarse display that agree but
# for one reading a step off are that, not a slip: the reading is judged against no
# less than this variance. A fine display (step well under the scatter) is unaffected.
ROUNDING_VARIANCE_BOUND = 0.25


@dataclass(frozen=True)
class OutlyingReading:
    """One reading far from its repeats, which agree among themselves."""

    index: int  # row of the observations
    gauge: str
    posture: str
    cycle: int
    t_s: float
    value_mm: float
    others_mean_mm: float
    n_others: int
    p_value: float  # corrected for every reading tested

    @property
    def deviation_mm(self) -> float:
        return self.value_mm - self.others_mean_mm

    def describe(self) -> str:
        """Which reading and how far out: ``z_x at zero, cycle 2 (t_s 80): 10.765 mm,
        +1999.8 µm from what its 4 repeats give``."""
        return (f"{self.gauge} at {self.posture}, cycle {self.cycle} (t_s {self.t_s:g}): "
                f"{self.value_mm:.6g} mm, {self.deviation_mm * UM_PER_MM:+.1f} µm from what "
                f"its {self.n_others} repeats give")

    def to_json(self) -> dict:
        return {"gauge": self.gauge, "posture": self.posture, "cycle": self.cycle,
                "t_s": self.t_s, "reading_mm": self.value_mm,
                "repeats_mean_mm": round(self.others_mean_mm, 6), "repeats": self.n_others,
                "deviation_mm": round(self.deviation_mm, 6), "p_value": self.p_value}


@dataclass(frozen=True)
class Outliers:
    """The readings named, and the joint offsets' verdict on the readings without them."""

    readings: tuple[OutlyingReading, ...]
    tested: int
    verdict_without: Verdict

    def to_json(self) -> dict:
        return {"readings": [r.to_json() for r in self.readings], "tested": self.tested,
                "without": self.verdict_without.to_record()}


def outlying_readings(obs: Observations, labels: RowLabels, noise: GaugeNoise,
                      alpha: float) -> tuple[list[OutlyingReading], int]:
    """The readings of ``obs`` that disagree with their repeats at level ``alpha``
    (corrected for the readings tested), and how many were tested; none for tabulated
    deviations. One at a time, the worst first, each then left out: a slip pulls its
    gauge's drift and so the readings beside it."""
    if not obs.raw:
        return [], 0
    layout = obs.layout
    tested = layout.repeat_size[layout.repeat_group] >= 3
    count = int(tested.sum())
    if not count:
        return [], 0
    # (bincount, not np.unique: that imports numpy.ma, a start-up cost of every diagnose)
    groups_tested = int(np.count_nonzero(np.bincount(layout.repeat_group[tested])))
    most = max(1, int(MOST_GROUPS_SHARE * groups_tested))
    keep = np.ones(len(obs), dtype=bool)
    found: list[OutlyingReading] = []
    while len(found) <= most:
        rows = np.flatnonzero(keep)
        worst = _worst(obs.values[rows], layout.t_s[rows], layout.repeat_group[rows],
                       layout.gauge[rows], noise, count, alpha)
        if worst is None:
            return found, count
        k, deviation, p_value, n_others = worst
        i = int(rows[k])
        found.append(OutlyingReading(i, str(labels.gauge[i]), str(labels.posture[i]),
                                     int(labels.cycle[i]), float(labels.t_s[i]),
                                     float(obs.values[i]), float(obs.values[i] - deviation),
                                     n_others, p_value))
        keep[i] = False
    return [], count  # too many to be slips: the campaign's disagreement, not a few readings'


def _worst(x: np.ndarray, t_s: np.ndarray, group: np.ndarray, gauge: np.ndarray,
           noise: GaugeNoise, count: int, alpha: float,
           ) -> tuple[int, float, float, int] | None:
    """The reading farthest from its repeats, when it is out at ``alpha`` (its p-value
    times ``count``) and its repeats agree without it: (its row, how far from what
    they give, the corrected p-value, how many they are); else None."""
    group = np.cumsum(np.bincount(group) > 0)[group] - 1  # numbered 0.. again, none empty
    size = np.bincount(group)
    tested = size[group] >= 3
    repeats = _RepeatsFit(x, t_s, group, size, gauge)
    spare = 1.0 - repeats.leverage
    usable = tested & (spare > 1e-9)
    stated = noise.source == "machine file"
    dof_noise = len(x) - repeats.parameters - 1
    if stated:
        variance = np.full(len(x), noise.variance)
    elif dof_noise < 1:
        return None
    else:  # the pooled scatter without the reading tested, which would inflate it
        variance = np.full(len(x), np.inf)
        variance[usable] = (float(np.sum(repeats.residual**2))
                            - repeats.residual[usable] ** 2 / spare[usable]) / dof_noise
    variance = np.maximum(variance, ROUNDING_VARIANCE_BOUND * noise.step_mm**2)
    usable &= variance > 0
    t2 = np.zeros(len(x))
    t2[usable] = repeats.residual[usable] ** 2 / (variance[usable] * spare[usable])
    for k in np.argsort(-t2, kind="stable"):
        if not usable[k]:
            return None
        p = float(2 * normal_sf(np.sqrt(t2[k]))) if stated else \
            float(f_sf(1.0, float(dof_noise), t2[k]))
        if p * count >= alpha:
            return None
        if repeats.others_agree(int(k), float(variance[k])):
            return (int(k), float(repeats.residual[k] / spare[k]), min(p * count, 1.0),
                    int(size[group[k]]) - 1)
    return None


class _RepeatsFit:
    """The readings fitted with their repeat group's mean and their gauge's slope in
    time: the residuals and each reading's leverage. The columns are orthogonal, so
    a leverage is 1/n of the group plus the reading's share of its gauge's centred
    time squared: no matrix."""

    def __init__(self, x: np.ndarray, t_s: np.ndarray, group: np.ndarray,
                 size: np.ndarray, gauge: np.ndarray) -> None:
        self.group, self.size, self.gauge = group, size, gauge
        # about each group's mean first: the readings are millimetres, their scatter
        # microns, and sums of their squares would lose the scatter
        centred = x - (np.bincount(group, weights=x) / size)[group]
        self.t = t_s - (np.bincount(group, weights=t_s) / size)[group]
        spread = np.bincount(gauge, weights=self.t**2)
        moved = spread > 0
        self.spread = np.where(moved, spread, np.inf)  # no slope where time stood still
        slope = np.bincount(gauge, weights=self.t * centred) / self.spread
        self.residual = centred - slope[gauge] * self.t
        self.leverage = 1.0 / size[group] + self.t**2 / self.spread[gauge]
        self.parameters = len(size) + int(moved.sum())

    def others_agree(self, i: int, variance: float) -> bool:
        """Whether the repeats of reading ``i`` agree among themselves once ``i`` is
        left out of the fit (so that its pull on its gauge's slope does not set them
        apart): their scatter about their mean within the noise."""
        others = np.flatnonzero(self.group == self.group[i])
        others = others[others != i]
        if len(others) < 2:
            return False
        # each residual as the fit without reading i leaves it (the cross-leverage
        # of two readings of one group and gauge: 1/n plus their centred times' share)
        pull = self.residual[i] / (1.0 - self.leverage[i])
        cross = 1.0 / self.size[self.group[i]] + \
            self.t[others] * self.t[i] / self.spread[self.gauge[i]]
        left = self.residual[others] + cross * pull
        scatter = float(np.sum((left - left.mean()) ** 2))
        return bool(chi2_sf(len(others) - 1, scatter / variance) >= OTHERS_AGREE_LEVEL)


def find_outliers(obs: Observations, labels: RowLabels, noise: GaugeNoise, alpha: float,
                  names: tuple[str, ...]) -> Outliers | None:
    """The readings that disagree with their repeats, with the verdict of the model
    ``names`` fitted without them (its noise measured again when it was measured
    from the repeats, which those readings inflated); None when there are none."""
    named, tested = outlying_readings(obs, labels, noise, alpha)
    if not named:
        return None
    keep = np.ones(len(obs), dtype=bool)
    keep[[r.index for r in named]] = False
    kept = obs.kept(keep)
    kept_noise = noise if noise.source == "machine file" else noise_for(kept)
    result = fit(kept, names, method="exact", weighting="gls", noise=kept_noise)
    return Outliers(tuple(named), tested, fit_verdict(result, alpha))


def described_outliers(result: FitResult, level: float = LEVEL) -> list[str]:
    """The readings of a fit that lie far from their repeats while those agree, each
    in words: a slip no model explains, which also swells a noise measured from the
    repeats until the fit passes (the write-back and a campaign's end say so)."""
    obs = result.observations
    found, tested = outlying_readings(obs, row_labels(obs), result.noise, level)
    return [f"{r.describe()} (p = {format_p(r.p_value)} over {tested} readings tested)"
            for r in found]
