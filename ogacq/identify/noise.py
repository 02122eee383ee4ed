"""The gauge noise a fit is judged against, and how readings are weighted by it.

A displayed reading is ``round((x + n) / s) * s``: the true value ``x``, the gauge's
own scatter ``n`` (sigma, stated in the machine file or measured from repeats)
and the display step ``s``. With the rounding phase of ``x`` uniform over the step,
the error of one reading has variance ``sigma^2 + s^2/12`` whatever the regime;
what changes with the regime is how much of it repeats. Readings repeated at
the same gauge, posture and approach side (the cycles) share ``x``, so they share
the part of the rounding error that the scatter does not dither away:

    c(sigma, s) = s^2 / (2 pi^2) * sum_k exp(-4 pi^2 k^2 sigma^2 / s^2) / k^2

(the variance of the mean rounding error over the phase: the sawtooth's Fourier
series damped by the scatter's characteristic function). ``c`` is ``s^2/12`` for a
dial far coarser than the noise (repeats read the same, the rounding never
averages out) and vanishes once ``sigma`` exceeds about ``s/2`` (rounding is
independent noise). So each repeat group has covariance
``w I + c 11'`` with ``w = sigma^2 + s^2/12 - c``: one model for every regime,
whitened group by group in O(n).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ogacq.identify.distributions import chi2_sf
from ogacq.identify.noise_averaged import AveragedReadings, averaged_readings, tail_p
from ogacq.identify.observations import Observations
from ogacq.model.units import UM_PER_MM

_HARMONICS = np.arange(1, 4001, dtype=float)
# Within a repeat group the weight of a difference between repeats is capped at
# this many times a plain reading's: with the scatter far below the display step
# those differences are rare whole-step flips, not Gaussian noise, and identical
# repeats must not get an infinite weight.
MAX_WITHIN_WEIGHT = 10.0
# Below this share of shared variance the rounding is independent noise: repeats
# then scatter as Gaussian readings do and their scatter can be tested.
DITHERED_SHARE = 0.05
ROUNDING_DOMINATES = 0.25
# The inversion of the scatter converges in under ten steps; bisection alone would
# need about 60 to reach the doubles' resolution.
MAX_ROOT_STEPS = 100
# Repeats that all read identically do not show the gauge's scatter to be zero, only
# small: it is taken as the largest under which they would all read identically this
# often (the verdict's level, consistency.LEVEL). A gauge scattering more shows such
# repeats less often than the level; one scattering less is judged against more
# noise than it has. So the false alarms stay within twice the level, where a scatter
# of zero gave them to 3 in 4 campaigns whose few repeats happened to agree (one
# cycle, two legs: 2 % of all campaigns; bench/bench_unseen.py).
IDENTICAL_REPEATS_LEVEL = 0.01
# A stated noise that the repeats' scatter refutes at the verdict's level
# (consistency.LEVEL, whose module imports this one) is replaced by the measured one:
# the verdict is then judged against the noise the readings carry.
STATED_NOISE_LEVEL = 0.01


# Up to this many harmonics the series is summed in plain floats: a numpy call on a
# few elements costs more than the arithmetic (the noise estimate sums it a few
# times per fit, and a 72-reading refit is budgeted in milliseconds).
_SCALAR_HARMONICS = 64


def _exp_sums(sigma_mm: float, step_mm: float) -> tuple[float, float]:
    """``sum_k exp(-a k^2) / k^2`` and ``sum_k exp(-a k^2)`` with ``a = 4 pi^2
    sigma^2 / s^2``: the series of ``c`` and of its derivative by sigma."""
    a = 4.0 * math.pi**2 * (sigma_mm / step_mm) ** 2
    # harmonics beyond exp(-a k^2) < 1e-30 add nothing a double can hold: skip them
    count = len(_HARMONICS) if a < 1e-12 else min(len(_HARMONICS), int(math.sqrt(70.0 / a)) + 1)
    if count <= _SCALAR_HARMONICS:
        terms = [math.exp(-a * k * k) for k in range(1, count + 1)]
        return sum(d / (k * k) for k, d in enumerate(terms, 1)), sum(terms)
    harmonics = _HARMONICS[:count]
    damped = np.exp(-a * harmonics**2)
    tail = 1.0 / _HARMONICS[-1] if a < 1e-12 else 0.0  # sum beyond the last harmonic
    return float(np.sum(damped / harmonics**2)) + tail, float(np.sum(damped))


def shared_rounding_variance(sigma_mm: float, step_mm: float) -> float:
    """``c(sigma, s)``: the variance of the rounding error that repeats share (mm^2)."""
    if step_mm <= 0:
        return 0.0
    return step_mm**2 / (2.0 * math.pi**2) * _exp_sums(sigma_mm, step_mm)[0]


def within_variance(sigma_mm: float, step_mm: float) -> float:
    """Variance of a reading about its repeat group's mean error (mm^2)."""
    return _within_variance_and_slope(sigma_mm, step_mm)[0]


def _within_variance_and_slope(sigma_mm: float, step_mm: float) -> tuple[float, float]:
    """:func:`within_variance` and its derivative by sigma, ``2 sigma + 4 sigma
    sum_k exp(-a k^2)`` (the series of ``c`` differentiated term by term, ``da/dsigma =
    2 a / sigma``; positive for sigma > 0, so the inversion below has one root), from
    one sum of the series: the inversion needs both at every step."""
    if step_mm <= 0:
        return max(sigma_mm**2 + step_mm**2 / 12.0, 0.0), 2.0 * sigma_mm
    damped_over_k2, damped = _exp_sums(sigma_mm, step_mm)
    total = sigma_mm**2 + step_mm**2 / 12.0
    shared = step_mm**2 / (2.0 * math.pi**2) * damped_over_k2
    return max(total - shared, 0.0), 2.0 * sigma_mm + 4.0 * sigma_mm * damped


def sigma_from_scatter(scatter_var: float, step_mm: float) -> float:
    """The gauge scatter sigma whose rounded repeats scatter with ``scatter_var``:
    inverts :func:`within_variance` (increasing in sigma) by Newton's method kept in
    a bracket, bisecting where a step would leave it (no source: the textbook
    safeguarded Newton), to a few units in the last place."""
    if scatter_var <= 0.0:
        return 0.0
    low, high = 0.0, math.sqrt(scatter_var) + step_mm  # within_variance(high) >= high^2
    sigma = math.sqrt(scatter_var)
    for _ in range(MAX_ROOT_STEPS):
        variance, slope = _within_variance_and_slope(sigma, step_mm)
        excess = variance - scatter_var
        if excess == 0.0:
            break
        low, high = (sigma, high) if excess < 0.0 else (low, sigma)
        step = excess / slope if slope > 0.0 else math.inf
        if abs(step) <= 4.0 * math.ulp(sigma):
            break  # at the root to the doubles' resolution
        newton = sigma - step
        sigma = newton if low < newton < high else 0.5 * (low + high)
        if high - low <= 4.0 * math.ulp(high):
            break
    return sigma


@dataclass(frozen=True)
class GaugeNoise:
    """The noise of one data set's readings and where it came from."""

    sigma_mm: float  # one reading's error, display rounding included
    source: str  # "machine file", "repeated readings", "gauge resolution"
    step_mm: float = 0.0  # display step
    scatter_mm: float | None = None  # the gauge's own scatter before rounding
    shared_var: float = 0.0  # part of the variance repeats share (mm^2)
    dof: int | None = None  # degrees of freedom of a measured noise
    pure_error_ss: float | None = None  # repeats about their means, mm^2
    repeats_scatter_mm: float | None = None  # what the repeats show, beside a stated noise
    # a stated noise the repeats refuted: the machine file's scatter (mm) and the
    # two-sided p of the repeats' scatter under it (the measured noise is used then)
    refuted_mm: float | None = None
    refuted_p: float | None = None
    # a stated noise of readings that average several values: the floor their count
    # gives beside the repeats' scatter (noise_averaged.py)
    averaged: AveragedReadings | None = None

    @property
    def variance(self) -> float:
        return self.sigma_mm**2

    @property
    def within_var(self) -> float:
        return max(self.variance - self.shared_var, 0.0)

    @property
    def measured(self) -> bool:
        return self.source == "repeated readings"

    @property
    def assumed(self) -> bool:
        """Neither stated nor measured: the display step stands in for the noise."""
        return self.source == "gauge resolution"

    @property
    def dithered(self) -> bool:
        """The rounding is independent between repeats: their scatter is Gaussian."""
        return self.shared_var <= DITHERED_SHARE * self.variance

    @property
    def rounding_dominated(self) -> bool:
        """A quarter or more of a reading's error repeats with the cycles: the display
        step, not the gauge, sets the error of a posture's mean."""
        return self.shared_var >= ROUNDING_DOMINATES * self.variance

    @classmethod
    def stated(cls, scatter_mm: float, step_mm: float) -> GaugeNoise:
        """A gauge that scatters ``scatter_mm`` behind a display of ``step_mm``, its
        readings repeating postures, so sharing the rounding."""
        return cls(math.hypot(scatter_mm, step_mm / math.sqrt(12.0)), "machine file", step_mm,
                   scatter_mm, shared_rounding_variance(scatter_mm, step_mm))

    def describe(self) -> str:
        extra = f", {self.dof} dof" if self.dof else ""
        if self.refuted_mm is not None and self.scatter_mm is not None:
            # readings that average several values: the line of their count sets a
            # reading's scatter beside the floor, one figure for the repeats
            seen = ("the repeats" if self.averaged is not None else
                    f"the repeats' {self.scatter_mm * UM_PER_MM:.2g} µm")
            extra += (f"; the machine file's {self.refuted_mm * UM_PER_MM:.2g} µm scatter "
                      f"disagrees with {seen} beyond chance (chi-square, "
                      f"{tail_p(self.refuted_p or 0.0)}): the repeats' is used")
        if self.averaged is not None:
            extra += f"; {self.averaged.describe()}"
        if self.rounding_dominated:
            extra += f"; mostly the {self.step_mm:g} mm display step, repeated by the cycles"
        if self.assumed:
            extra += "; assumed: state gauge_repeatability_mm to judge against the gauge"
        return f"{self.sigma_mm:.4g} mm ({self.source}{extra})"


def read_identically(pure_error_ss: float, dof: int, step_mm: float) -> bool:
    """Whether repeats whose sum of squares about their means is ``pure_error_ss`` all
    read the same value: repeats that differ do so by a display step at least, so
    anything far below one is the doubles' rounding of equal readings' means."""
    return dof > 0 and pure_error_ss <= (1e-6 * step_mm) ** 2


def identical_pair_probability(sigma_mm: float, step_mm: float) -> float:
    """How often two readings of one machine state read the same display value: their
    difference ``d`` is normal with variance ``2 sigma^2`` and, the rounding phase
    uniform over the step, they share a value with probability ``max(0, 1 - |d| / s)``;
    its mean, ``2 Phi(1/tau) - 1 - 2 tau (phi(0) - phi(1/tau))`` with
    ``tau = sqrt(2) sigma / s`` (no source: the integral, by hand)."""
    if sigma_mm <= 0:
        return 1.0
    tau = math.sqrt(2.0) * sigma_mm / step_mm
    z = 1.0 / tau
    density = math.exp(-0.5 * z * z) / math.sqrt(2.0 * math.pi)
    inside = math.erf(z / math.sqrt(2.0))  # 2 Phi(z) - 1
    return max(inside - 2.0 * tau * (1.0 / math.sqrt(2.0 * math.pi) - density), 0.0)


def identical_repeats_scatter(groups: int, step_mm: float) -> float:
    """The largest gauge scatter under which ``groups`` repeat groups all read
    identically with probability ``IDENTICAL_REPEATS_LEVEL``. Each group is counted by
    one pair of its readings (a group of more agrees less often than one pair of it), so
    the scatter found is, if anything, too large: the verdict errs toward 'within the
    noise'."""
    if groups <= 0 or step_mm <= 0:
        return 0.0
    target = IDENTICAL_REPEATS_LEVEL ** (1.0 / groups)
    low, high = 0.0, step_mm
    while identical_pair_probability(high, step_mm) > target:
        high *= 2.0
    for _ in range(60):  # bisection to a few parts in 1e18 of the step
        middle = 0.5 * (low + high)
        if identical_pair_probability(middle, step_mm) > target:
            low = middle
        else:
            high = middle
    return high


def _identical_repeats_noise(obs: Observations, step_mm: float, dof: int) -> GaugeNoise:
    """The noise of repeats that all read identically: ``identical_repeats_scatter`` as
    the scatter within the groups and the whole rounding shared, a bound on the
    variance of a mean for every scatter in that range (``c`` never exceeds
    ``s^2/12``). The scatter alone would dither the rounding and credit a mean with
    less variance than it has (the 10 um display's 0.3 um gauge: 5 % false alarms)."""
    groups = int(np.count_nonzero(obs.layout.repeat_size > 1))
    scatter = identical_repeats_scatter(groups, step_mm)
    rounding = step_mm**2 / 12.0
    return GaugeNoise(math.sqrt(scatter**2 + rounding), "repeated readings", step_mm,
                      scatter, rounding, dof, 0.0)


def pure_error(obs: Observations) -> tuple[float, int] | None:
    """(sum of squares, dof) of the readings about their repeat groups' means: the
    scatter of the cycles, which needs no model."""
    if not obs.raw:
        return None
    group = obs.layout.repeat_group
    size = obs.layout.repeat_size
    dof = len(obs) - len(size)
    if dof <= 0:
        return None
    means = np.bincount(group, weights=obs.values) / size
    return float(np.sum((obs.values - means[group]) ** 2)), int(dof)


def noise_for(obs: Observations) -> GaugeNoise:
    """The noise of INTERCHANGE.md: stated in the machine file, else measured from the
    repeats, else (tabulated deviations, no repeats) the display step. Estimated once
    per observations (a refit, its verdict and its report each ask): kept with the
    values, machine and layout it came from, estimated again when one changed."""
    known = obs.derived.get("noise")
    if known is not None and known[0] is obs.layout and known[1] == obs.machine \
            and known[2].shape == obs.values.shape and bool((known[2] == obs.values).all()):
        return known[3]
    noise = _estimate_noise(obs)
    obs.derived["noise"] = (obs.layout, obs.machine, obs.values.copy(), noise)
    return noise


def stated_noise_p(stated_mm: float, step_mm: float, pure_error_ss: float,
                   dof: int) -> float | None:
    """Two-sided p of the repeats' scatter about their means (``pure_error_ss`` over
    ``dof``) under a stated gauge scatter: ``ss / w`` is chi-square with ``dof``
    degrees of freedom, ``w`` the variance the stated noise gives a reading about its
    group's mean (the test of a variance, NIST/SEMATECH e-Handbook of Statistical
    Methods, 1.3.5.8). None where the repeats cannot test it: the rounding not
    dithered by the stated scatter (repeats then differ by whole display steps, not
    Gaussian noise), or repeats that all read identically."""
    within = within_variance(stated_mm, step_mm)
    shared = shared_rounding_variance(stated_mm, step_mm)
    total = stated_mm**2 + step_mm**2 / 12.0
    if dof <= 0 or within <= 0 or shared > DITHERED_SHARE * total or \
            read_identically(pure_error_ss, dof, step_mm):
        return None
    upper = float(chi2_sf(dof, pure_error_ss / within))
    return min(1.0, 2.0 * min(upper, 1.0 - upper))


def _estimate_noise(obs: Observations) -> GaugeNoise:
    step = obs.machine.gauge_resolution_mm
    measured = pure_error(obs)
    shared = obs.raw  # only raw readings are known to repeat
    scatter = None
    if measured is not None:
        ss, dof = measured
        scatter = sigma_from_scatter(ss / dof, step)
    stated = obs.machine.gauge_repeatability_mm
    if stated is not None:
        p = None if measured is None else stated_noise_p(stated, step, *measured)
        # the stated noise is a value's: a reading that averages several has a floor
        # below it, said beside the repeats' scatter (noise_averaged.py)
        averaged = averaged_readings(
            obs.averaged, stated, within_variance(stated, step),
            shared_rounding_variance(stated, step), measured, testable=p is not None,
            level=STATED_NOISE_LEVEL)
        # only a stated noise above the scatter is replaced: repeats that scatter more
        # may hold physics that varies between them (a drift, a wind-up after other
        # travels), which the model must explain, not the noise absorb
        if p is not None and p < STATED_NOISE_LEVEL and scatter is not None \
                and measured is not None and scatter < stated:
            return _measured_noise(obs, step, measured, scatter, refuted_mm=stated,
                                   refuted_p=p, averaged=averaged)
        # GaugeNoise.stated's numbers, built at once with what the repeats show
        # (dataclasses.replace costs more than the noise it copies)
        return GaugeNoise(math.hypot(stated, step / math.sqrt(12.0)), "machine file", step,
                          stated, shared_rounding_variance(stated, step) if shared else 0.0,
                          repeats_scatter_mm=scatter, averaged=averaged)
    if measured is not None and read_identically(*measured, step):
        return _identical_repeats_noise(obs, step, measured[1])
    if measured is not None:
        assert scatter is not None
        return _measured_noise(obs, step, measured, scatter)
    return GaugeNoise(step, "gauge resolution", step)


def _measured_noise(obs: Observations, step: float, measured: tuple[float, int],
                    scatter: float, **said: Any) -> GaugeNoise:
    """The noise the repeats show: their scatter about their means and the rounding
    they share, ``c`` of one gauge value's scatter: the repeats' own (inverted), or
    where readings average several values, the values' scatter within each reading
    (``averaged_sd_mm``). Inverting the means' scatter as one value's made a gauge
    far quieter than its step (issue 37.7: 0.29 µm for means of 16 values of 0.5 µm on
    a 1 µm display; a true model's F per dof 0.07-0.23). Correlated values only make
    ``c`` larger: the noise errs high, not low."""
    ss, dof = measured
    per_value = _value_scatter(obs, step)
    if per_value is None:
        return GaugeNoise(math.hypot(scatter, step / math.sqrt(12.0)), "repeated readings",
                          step, scatter, shared_rounding_variance(scatter, step), dof, ss,
                          **said)
    shared = shared_rounding_variance(per_value, step)
    return GaugeNoise(math.sqrt(ss / dof + shared), "repeated readings", step, per_value,
                      shared, dof, ss, **said)


def _value_scatter(obs: Observations, step: float) -> float | None:
    """A gauge value's scatter (before its rounding) from the values the readings are
    the means of: their sample variances pooled by their dof, inverted as one value's
    (``sigma_from_scatter``); None where no reading recorded two values or more."""
    counts, spread = obs.averaged, obs.averaged_sd_mm
    if counts is None or spread is None:
        return None
    use = (counts >= 2) & np.isfinite(spread)
    if not use.any():
        return None
    dof = counts[use] - 1
    return sigma_from_scatter(float(np.sum(dof * spread[use] ** 2) / np.sum(dof)), step)


def group_whitener(obs: Observations, noise: GaugeNoise) -> GroupWhitener:
    """``GroupWhitener(obs, noise)``, built once per layout and noise (kept with the
    observations; read-only, like every whitener)."""
    known = obs.derived.get("group whitener")
    if known is not None and known[0] is obs.layout and known[1] == noise:
        return known[2]
    groups = GroupWhitener(obs, noise)
    obs.derived["group whitener"] = (obs.layout, noise, groups)
    return groups


class GroupWhitener:
    """``sigma V^-1/2`` for raw readings, repeat group by repeat group: the difference
    of a reading from its group's mean is scaled by ``sigma / sqrt(w)``, the group's
    mean by ``sigma / sqrt(w + n_g c)``. Applied along the last axis."""

    def __init__(self, obs: Observations, noise: GaugeNoise) -> None:
        layout = obs.layout  # the groups' structure is the layout's, built once
        self.group = layout.repeat_group
        self.size = layout.repeat_size.astype(float)
        ref = noise.variance if noise.variance > 0 else 1.0
        within = max(noise.within_var, ref / MAX_WITHIN_WEIGHT**2)
        self.within_scale = math.sqrt(ref / within)
        self.mean_scale = np.sqrt(ref / (within + self.size * noise.shared_var))
        self._order, self._starts = layout.repeat_order
        self.reading_mean_scale = self.mean_scale[self.group]  # (n,) once, not per call
        self._zeros: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None

    def zeros(self, onehot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Each gauge's zero whitened, (n, G) from the gauges' one-hot (n, G): what it
        adds to every reading of that gauge; and its squared norm (G,). Formed once
        per whitener (``fit.Weighting`` projects the zeros out at every step)."""
        known = self._zeros
        if known is None or known[0] is not onehot:
            zero = onehot * self.reading_mean_scale[:, None]
            known = (onehot, zero, np.add.reduce(zero * zero, axis=0))
            self._zeros = known
        return known[1], known[2]

    def group_means(self, x: np.ndarray) -> np.ndarray:
        """(..., G) means of each group along the last axis."""
        sums = np.add.reduceat(x[..., self._order], self._starts, axis=-1)
        return sums / self.size

    def __call__(self, x: np.ndarray) -> np.ndarray:
        means = self.group_means(x)[..., self.group]
        return (x - means) * self.within_scale + means * self.reading_mean_scale

    def group_space(self, whitened: np.ndarray) -> np.ndarray:
        """(..., G) the mean part of whitened vectors, one coordinate per group with
        the same squared norm: ``sqrt(n_g)`` times the group's mean."""
        return self.group_means(whitened) * np.sqrt(self.size)
