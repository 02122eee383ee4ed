"""The Monte-Carlo check of the budget (JCGM 101:2008, GUM Supplement 1).

Every evaluated input is drawn from the distribution its budget row states
(JCGM 101:2008 6.4: normal, rectangular), the readings they imply are built and
the project's own fit is run again on each draw (7.2-7.4); the standard deviation
of the refitted parameters is their standard uncertainty (7.6), the 2.5 % and
97.5 % quantiles their probabilistically symmetric 95 % coverage interval (7.7).
Where the fit is close to linear the two must agree: the budget's u_c within 10 %
(docs/calibration-record.md section 3; JCGM 101:2008 section 8 validates the GUM
framework the same way, on interval endpoints).

Draws, per trial:
- each reading's error: the gauge's scatter (normal) behind the display's
  rounding. The true value's place within the display step is unknown, uniform
  (rectangular), and shared by the repeats of one posture; a displayed reading is
  ``round((phase + scatter) / step) * step`` and its error that minus ``phase``.
  This is the physics the budget's rounding correlation comes from.
- each gauge's scale error (normal, the certificate's U/k over its span), one per
  gauge for all its readings.
- the legs' temperature: rectangular over the start-end range plus the
  thermometer's normal error; the readings referred to 20 degC through the exact
  model (the leg lengths changed by ``alpha L (T - 20)``), not its derivative.
- the register's rounding of each written offset: rectangular, half a step.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ogacq.identify.fit import FitResult, Weighting, gauss_newton
from ogacq.identify.observations import Observations
from ogacq.model.machine import REFERENCE_TEMPERATURE_C
from ogacq.model.parameters import indices
from ogacq.uncertainty.budget import Budget, solution_operator, uncertainty_budget
from ogacq.uncertainty.inputs import BudgetInputs
from ogacq.uncertainty.sources import LEG_LENGTHS, calibration_span

CHUNK = 1000  # draws per vectorised batch: bounds memory on long campaigns
AGREEMENT_TOLERANCE = 0.10  # docs/calibration-record.md section 3
# One-sided 95 % normal quantile: the agreement is claimed when the ratio's
# distance from 1 plus this many standard errors of the MC std stays within tolerance.
ONE_SIDED_95 = 1.6449


@dataclass(frozen=True)
class MonteCarlo:
    names: tuple[str, ...]
    draws: int
    seed: int
    mean: np.ndarray  # of the draws (the value referred to 20 degC when temperature is known)
    std: np.ndarray  # the MC standard uncertainty of each parameter
    low: np.ndarray  # 2.5 % quantile
    high: np.ndarray  # 97.5 % quantile
    u_c: np.ndarray  # the budget's combined standard uncertainty
    ratio_se: np.ndarray  # standard error of std / u_c from the draws' own kurtosis
    converged_fraction: float
    seconds: float

    @property
    def ratio(self) -> np.ndarray:
        return self.std / self.u_c

    @property
    def agreement(self) -> float:
        """The largest relative difference between the MC std and the budget's u_c."""
        return float(np.max(np.abs(self.ratio - 1.0)))

    def agrees(self, tolerance: float = AGREEMENT_TOLERANCE) -> bool:
        """Every parameter's ratio within ``tolerance`` of 1 at 95 % confidence (one-sided):
        the claim holds for the distributions, not just for these draws."""
        return bool(np.all(np.abs(self.ratio - 1.0) + ONE_SIDED_95 * self.ratio_se
                           <= tolerance))

    def to_json(self) -> dict:
        """The record's ``monte_carlo``."""
        def per(values: np.ndarray) -> dict:
            return {n: round(float(v), 9) for n, v in zip(self.names, values, strict=True)}
        return {"draws": self.draws, "seed": self.seed, "u_mm": per(self.std),
                "u_c_mm": per(self.u_c), "ratio": per(self.ratio),
                "agreement": round(self.agreement, 4),
                "agrees_within_10_percent": self.agrees(),
                "mean_mm": per(self.mean),
                "interval_95_mm": {n: [round(float(lo), 9), round(float(hi), 9)] for n, lo, hi
                                   in zip(self.names, self.low, self.high, strict=True)},
                "converged_fraction": self.converged_fraction,
                "seconds": round(self.seconds, 3)}


def monte_carlo(obs: Observations, result: FitResult, inputs: BudgetInputs, *,
                draws: int = 2000, seed: int = 0, budget: Budget | None = None) -> MonteCarlo:
    """Propagate the inputs' distributions through the fit ``draws`` times."""
    if draws < 10:
        raise ValueError(f"draws must be at least 10, got {draws}")
    budget = budget or uncertainty_budget(obs, result, inputs)
    free = indices(result.names)
    weighting = Weighting(obs, result.weighting, result.noise)
    linear = solution_operator(result) if result.method == "linear" else None
    std = result.std
    # Steps far below the parameters' std change nothing a user would read.
    tolerance = 1e-4 * np.where(np.isfinite(std) & (std > 0), std, np.inf)
    rng = np.random.default_rng(seed)
    estimates = np.empty((draws, len(free)))
    converged = np.empty(draws, dtype=bool)
    start = time.perf_counter()
    for lo in range(0, draws, CHUNK):
        count = min(draws, lo + CHUNK) - lo
        y = obs.values[None] + perturbations(obs, result.theta, inputs, rng, count)
        if linear is not None:  # the fit is one linear step: exactly this operator
            estimates[lo:lo + count] = result.values + (y - obs.values) @ linear.T
            converged[lo:lo + count] = True
        else:
            theta, conv = gauss_newton(obs, y, free, result.theta, weighting,
                                       result.identifiability.rank, tolerance=tolerance)
            estimates[lo:lo + count] = theta[:, free]
            converged[lo:lo + count] = conv
        if inputs.register_step_mm is not None:
            written = np.array([n.startswith("joint_offset.") for n in result.names])
            half = inputs.register_step_mm / 2
            estimates[lo:lo + count, written] += rng.uniform(-half, half,
                                                             (count, int(written.sum())))
    seconds = time.perf_counter() - start
    sd = estimates.std(axis=0, ddof=1)
    centred = estimates - estimates.mean(axis=0)
    m2 = np.mean(centred**2, axis=0)
    kurtosis = np.mean(centred**4, axis=0) / np.where(m2 > 0, m2**2, 1.0)
    u_c = np.array([o.u_c for o in budget.outputs])
    # var(s^2)/sigma^4 ~ (kurtosis - 1)/N, so s has relative se sqrt((kurtosis - 1)/(4N))
    ratio_se = np.sqrt(np.maximum(kurtosis - 1.0, 0.0) / (4.0 * draws)) * sd / u_c
    return MonteCarlo(result.names, draws, seed, estimates.mean(axis=0), sd,
                      np.quantile(estimates, 0.025, axis=0),
                      np.quantile(estimates, 0.975, axis=0), u_c, ratio_se,
                      float(converged.mean()), seconds)


def perturbations(obs: Observations, theta: np.ndarray, inputs: BudgetInputs,
                  rng: np.random.Generator, count: int) -> np.ndarray:
    """(count, m) changes of the observations: one draw of every evaluated input each."""
    lay = obs.layout
    n = len(lay)
    errors = np.zeros((count, n))
    if inputs.gauge_noise_mm is not None:
        errors += rng.normal(0.0, inputs.gauge_noise_mm, (count, n))
    step = inputs.resolution_mm
    if step is not None:
        group = lay.repeat_group
        phase = rng.uniform(0.0, step, (count, int(group.max()) + 1))[:, group]
        errors = np.round((phase + errors) / step) * step - phase
    out = errors if obs.combination is None else errors @ obs.combination.T
    for g, key in enumerate(lay.gauge_names()):
        u = inputs.calibration_u_mm.get(key)
        if u:
            vector, _ = calibration_span(obs, g)
            out += rng.normal(0.0, u, (count, 1)) * vector[None]
    alpha_l = inputs.alpha_l_mm_per_k
    if alpha_l is not None and inputs.ambient_range_c is not None:
        low, high = inputs.ambient_range_c
        temperature = rng.uniform(low, high, count) + rng.normal(0.0, inputs.thermometer_u_c,
                                                                 count)
        growth = alpha_l * (temperature - REFERENCE_TEMPERATURE_C)
        warm = np.repeat(theta[None], count, axis=0)
        warm[:, indices(LEG_LENGTHS)] += growth[:, None]
        # the readings as the legs at 20 degC would have given them
        out -= obs.predict(warm) - obs.predict(theta[None])
    return out

