"""Is a fit within the gauge noise? A proper test, judged against the noise, never
against the misfit itself.

Two cases:
- the noise is known (the machine file states the repeatability, or for tabulated
  deviations its display resolution): chi-square test of the weighted residual sum;
- the noise is measured from readings repeated over the cycles (pure error): the
  lack-of-fit F-test, which compares the misfit of the posture means with the
  scatter of the repeats and needs no model of the noise level.

A misfit confined to one gauge at one posture (a knocked stand, a sticking spindle)
hardly moves the overall sum, so the verdict also tests the worst such cell
against what noise would leave in it, Bonferroni-corrected over the cells; the
two tests share the significance level.

The same noise serves the nested-model tests of the effect selection.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import stats

from ogacq.identify.noise import noise_for, pure_error
from ogacq.identify.observations import Observations

# Significance level of every test here. 1 % rather than 5 %: a false "inconsistent"
# sends someone to re-tune a machine, and the selection only runs past this gate,
# so it also bounds the rate of effects claimed on a consistent campaign.
ALPHA = 0.01


@dataclass(frozen=True)
class NoiseBasis:
    """The gauge noise sigma a verdict is judged against, and where it came from."""

    sigma_mm: float
    source: str  # "machine file", "repeated readings", "gauge resolution"
    dof: int | None = None  # degrees of freedom of a measured sigma; None: stated
    pure_error_ss: float | None = None  # sum of squares of the repeats about their means

    @property
    def variance(self) -> float:
        return self.sigma_mm**2

    @property
    def measured(self) -> bool:
        return self.dof is not None

    def describe(self) -> str:
        extra = f", {self.dof} dof" if self.dof else ""
        return f"{self.sigma_mm:.4g} mm ({self.source}{extra})"


def noise_basis(obs: Observations) -> NoiseBasis:
    """The noise of INTERCHANGE.md: from the machine file, else from repeated readings,
    else the display step. A stated repeatability is combined with the display
    rounding (step^2 / 12), which every displayed reading carries on top of it."""
    machine = obs.machine
    estimate = noise_for(obs)
    if estimate.source == "machine file":
        sigma = math.hypot(estimate.sigma_mm, machine.gauge_resolution_mm / math.sqrt(12.0))
        return NoiseBasis(sigma, "machine file")
    if estimate.source == "repeated readings":
        measured = pure_error(obs)
        assert measured is not None
        sigma_pe, dof_pe = measured
        return NoiseBasis(estimate.sigma_mm, estimate.source, dof_pe, sigma_pe**2 * dof_pe)
    return NoiseBasis(estimate.sigma_mm, estimate.source)


@dataclass(frozen=True)
class CellTest:
    """The worst cell (one gauge at one posture, or one tabulated deviation)."""

    cell: str  # "y_x at max"
    chi2: float  # its misfit in units of the noise variance
    expected: float  # what noise alone would leave there
    p_value: float  # corrected for the number of cells looked at
    cells: int


@dataclass(frozen=True)
class Verdict:
    rss: float  # weighted residual sum of squares, mm^2
    dof: int
    rms_mm: float  # residual rms, gauge zeros removed
    chi2_dof: float  # rss / (sigma^2 dof): 1 when the fit is within the noise
    test: str  # "chi-square" or "lack-of-fit F"
    statistic: float
    overall_p: float  # of the chi-square / lack-of-fit test alone
    p_value: float  # of the verdict (both tests, Bonferroni-combined)
    consistent: bool
    worst_cell: CellTest | None = None

    def describe(self) -> str:
        word = "consistent" if self.consistent else "INCONSISTENT"
        stat = ("chi2" if self.test == "chi-square" else "F") + f" = {self.statistic:.4g}"
        text = (f"{word} with the gauge noise: {self.test} test, {stat}, "
                f"p = {format_p(self.overall_p)} (chi2/dof {self.chi2_dof:.3g}, "
                f"{self.dof} dof, rms {self.rms_mm:.4g} mm)")
        if self.worst_cell is not None:
            c = self.worst_cell
            text += (f"; worst cell {c.cell}: chi2 {c.chi2:.3g} for {c.expected:.2g} expected, "
                     f"p = {format_p(c.p_value)} over {c.cells} cells")
        return text

    def to_json(self) -> dict:
        chi2_dof = round(self.chi2_dof, 4) if math.isfinite(self.chi2_dof) else None
        return {"chi2_dof": chi2_dof, "rms_mm": round(self.rms_mm, 6),
                "consistent": self.consistent}


def format_p(p: float) -> str:
    return f"{p:.3g}" if p >= 1e-4 else f"{p:.1e}"


def judge(rss: float, dof: int, rms_mm: float, noise: NoiseBasis, alpha: float = ALPHA,
          worst_cell: CellTest | None = None) -> Verdict:
    """The verdict on a fit with weighted residual sum ``rss`` and ``dof`` degrees of
    freedom, and its worst cell when known. With no degrees of freedom nothing can
    be judged: called consistent."""
    if dof <= 0:
        return Verdict(rss, dof, rms_mm, float("nan"), "none", float("nan"), 1.0, 1.0, True)
    test, statistic, p = _overall(rss, dof, noise)
    combined = p if worst_cell is None else min(1.0, 2.0 * min(p, worst_cell.p_value))
    return Verdict(rss, dof, rms_mm, rss / (noise.variance * dof), test, statistic, p,
                   combined, combined >= alpha, worst_cell)


def _overall(rss: float, dof: int, noise: NoiseBasis) -> tuple[str, float, float]:
    lack_dof = dof - (noise.dof or 0)
    if noise.measured and noise.pure_error_ss is not None and lack_dof > 0:
        # The misfit splits into the repeats' scatter (pure error) and the misfit of
        # the posture means (lack of fit); a model whose predictions vary within a
        # repeat group (thermal drift) may fit below the pure error: no lack of fit.
        lack = max(rss - noise.pure_error_ss, 0.0) / lack_dof
        f_stat = lack / noise.variance  # the repeats' scatter, floored at the display step
        return "lack-of-fit F", f_stat, float(stats.f.sf(f_stat, lack_dof, noise.dof))
    chi2 = rss / noise.variance
    return "chi-square", chi2, float(stats.chi2.sf(chi2, dof))


def nested_test(rss_small: float, rss_big: float, added: int, dof_big: int,
                noise: NoiseBasis) -> tuple[float, float]:
    """Does the bigger of two nested models fit significantly better? Returns (F, p).

    The improvement per added parameter is compared with the larger of the gauge
    noise and what the bigger model still leaves unexplained: when the bigger
    model is itself within the noise this is the likelihood-ratio test; when it is
    not, an effect is only credited with what it explains beyond the remaining
    misfit (the classical F-test), so that a partial fit of an unknown error is
    not mistaken for the effect.
    """
    f_stat, p = nested_tests(rss_small, np.array([rss_big]), np.array([added]),
                             np.array([dof_big]), noise)
    return float(f_stat[0]), float(p[0])


def nested_tests(rss_small: float, rss_big: np.ndarray, added: np.ndarray,
                 dof_big: np.ndarray, noise: NoiseBasis) -> tuple[np.ndarray, np.ndarray]:
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
    p_noise = (stats.f.sf(f_stat, k, noise.dof) if noise.measured
               else stats.chi2.sf(f_stat * k, k))
    p = np.where(by_misfit, stats.f.sf(f_stat, k, dof), p_noise)
    return np.where(valid, f_stat, 0.0), np.where(valid, p, 1.0)


def information_criteria(rss: float | np.ndarray, n_params: int | np.ndarray, n_data: int,
                         noise: NoiseBasis) -> tuple[float | np.ndarray, float | np.ndarray]:
    """(AIC, BIC) up to a common constant, the noise taken as known; element-wise for
    arrays of candidates."""
    chi2 = rss / noise.variance
    return chi2 + 2.0 * n_params, chi2 + n_params * float(np.log(max(n_data, 2)))
