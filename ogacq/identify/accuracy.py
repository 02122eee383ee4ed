"""How accurately will a planned campaign identify the parameters?

Two answers that should agree: the analytic covariance of the linearised fit
at the assumed geometry, and a Monte-Carlo of the full nonlinear fit on
readings simulated with the exact model, gauge noise and display rounding.
When they disagree, the linearisation is not to be trusted for this plan.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ogacq.identify.fit import Weighting, design_rank, gauss_newton
from ogacq.identify.identifiability import Identifiability, assess, plausible_ranges
from ogacq.identify.noise import GaugeNoise
from ogacq.identify.observations import Observations, readings_observations
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import NOMINAL, indices, vector
from ogacq.protocol.plan import ProtocolConfig, planned_layout

CHUNK = 1000  # trials per vectorised batch: bounds memory at a few hundred MB
# A trial ending beyond this many times a parameter's plausible range has run off along
# a direction the readings do not bound (a travel of a few mm leaves the offsets and
# the lengths free to grow together: the exact model's legs lengthen to 1e12 mm, the
# cost still falling). No real machine is there, and a plan whose std is below the
# plausible range (an identifiable one) puts no trial there (100 std: p < 1e-300), so
# only such unbounded trials are left out of the std and the bias, and counted.
RAN_OFF_RANGES = 100.0


@dataclass
class AccuracyPrediction:
    names: tuple[str, ...]
    noise_mm: float
    n_readings: int
    analytic_std: np.ndarray
    identifiability: Identifiability
    trials: int = 0
    mc_std: np.ndarray | None = None
    mc_bias: np.ndarray | None = None
    converged_fraction: float | None = None
    mc_seconds: float | None = None
    ran_off_fraction: float | None = None  # trials beyond RAN_OFF_RANGES, left out

    def to_json(self) -> dict:
        out = {
            "parameters": list(self.names),
            "noise_mm": self.noise_mm,
            "readings": self.n_readings,
            "analytic_std": dict(zip(self.names, map(float, self.analytic_std), strict=True)),
            "identifiable": self.identifiability.identifiable,
            "condition_number": self.identifiability.condition_number,
            "correlated_pairs": [list(p) for p in self.identifiability.correlated_pairs],
        }
        if self.mc_std is not None and self.mc_bias is not None:
            out["monte_carlo"] = {
                "trials": self.trials,
                "std": dict(zip(self.names, map(_finite, self.mc_std), strict=True)),
                "bias": dict(zip(self.names, map(_finite, self.mc_bias), strict=True)),
                "converged_fraction": self.converged_fraction,
                "seconds": self.mc_seconds,
                "ran_off_fraction": self.ran_off_fraction,
            }
        return out


def _finite(value: float) -> float | None:
    """A number for JSON: None where no trial was left to give one."""
    return float(value) if np.isfinite(value) else None


def planned_observations(machine: MachineSpec, *, postures: Sequence[str | float] = (),
                         cycles: int = 3, protocol: ProtocolConfig | None = None,
                         ) -> Observations:
    """The readings a plan takes (values zero): ``protocol`` (a scan too), else the
    ``postures`` of every leg repeated ``cycles`` times."""
    if protocol is None:
        protocol = ProtocolConfig(postures=tuple(postures), cycles=cycles)
    layout = planned_layout(protocol, machine)
    return readings_observations(machine, layout, np.zeros(len(layout)), "plan")


def predict_accuracy(obs: Observations, names: Sequence[str], noise_mm: float, *,
                     truth: Mapping[str, float] | None = None, trials: int = 0,
                     seed: int = 0, rounding_mm: float | None = None,
                     on_trials: Callable[[int, int], None] | None = None,
                     ) -> AccuracyPrediction:
    """Predicted std of ``names`` for the readings laid out in ``obs`` (its values are
    ignored). ``rounding_mm``: the gauge display step applied to simulated readings.
    ``on_trials(done, total)`` is told after each batch of Monte-Carlo trials."""
    names = tuple(names)
    free = indices(names)
    theta_true = vector(truth)
    # Display rounding adds its own variance (step^2 / 12) to every reading, and the
    # part of it the scatter does not dither repeats with the cycles.
    noise = GaugeNoise.stated(noise_mm, rounding_mm or 0.0)
    w = Weighting(obs, "ols", noise)
    jw = w.jac(obs.jacobian(theta_true[None], free))[0]
    ident, cov = assess(jw, w.noise_cov(), names, noise.sigma_mm)
    pred = AccuracyPrediction(names, noise_mm, len(obs), np.sqrt(np.diag(cov)), ident)
    if trials <= 0:
        return pred

    rank = design_rank(jw, plausible_ranges(names))
    rng = np.random.default_rng(seed)
    clean = obs.predict(theta_true)
    # Steps far below the std change nothing a user would read.
    tolerance = 1e-4 * np.where(np.isfinite(pred.analytic_std), pred.analytic_std, np.inf)
    estimates = np.empty((trials, len(free)))
    converged = np.empty(trials, dtype=bool)
    start = time.perf_counter()
    # Batches of at most CHUNK, and about twenty of them when a watcher is told of each
    # (the same draws: one generator fills them in order, whatever the batch sizes).
    chunk = CHUNK if on_trials is None else max(50, min(CHUNK, -(-trials // 20)))
    for lo in range(0, trials, chunk):
        hi = min(trials, lo + chunk)
        y = clean + rng.normal(0.0, noise_mm, (hi - lo, len(clean)))
        if rounding_mm:
            y = np.round(y / rounding_mm) * rounding_mm
        theta, conv = gauss_newton(obs, y, free, NOMINAL, w, rank, tolerance=tolerance)
        estimates[lo:hi] = theta[:, free]
        converged[lo:hi] = conv
        if on_trials is not None:
            on_trials(hi, trials)
    pred.mc_seconds = time.perf_counter() - start
    pred.trials = trials
    bound = RAN_OFF_RANGES * plausible_ranges(names)
    kept = np.all(np.abs(estimates - NOMINAL[free]) <= bound, axis=1)
    pred.ran_off_fraction = float(1.0 - kept.mean())
    with np.errstate(invalid="ignore", divide="ignore"):  # NaN when none is kept
        pred.mc_std = estimates[kept].std(axis=0, ddof=1) if kept.sum() > 1 else \
            np.full(len(free), np.nan)
        pred.mc_bias = estimates[kept].mean(axis=0) - theta_true[free] if kept.any() else \
            np.full(len(free), np.nan)
    pred.converged_fraction = float((converged & kept).mean())
    return pred
