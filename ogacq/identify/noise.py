"""The gauge noise a fit is judged against: stated, measured from repeats, or the
display step. Never the misfit itself, which would call any model consistent."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ogacq.identify.observations import Observations


@dataclass(frozen=True)
class NoiseEstimate:
    sigma_mm: float  # per reading, display rounding included
    source: str  # "machine file", "repeated readings", "gauge resolution"
    dof: int | None = None  # degrees of freedom of a measured estimate
    # The display step when the noise is too small to dither it: repeated readings
    # then round the same way every cycle, and that error does not average out.
    repeated_rounding_mm: float | None = None

    def describe(self) -> str:
        extra = f", {self.dof} dof" if self.dof else ""
        if self.repeated_rounding_mm:
            extra += f"; mostly the {self.repeated_rounding_mm:g} mm display step"
        return f"{self.sigma_mm:.4g} mm ({self.source}{extra})"


def repeat_groups(obs: Observations) -> np.ndarray:
    """For each raw reading, the index of its group of repeats: same gauge, same
    joint coordinates, same approach side (the cycles of one posture)."""
    lay = obs.layout
    keys = np.column_stack([lay.gauge, np.round(lay.q_mm, 6), lay.approach])
    return np.unique(keys, axis=0, return_inverse=True)[1].ravel()


def pure_error(obs: Observations) -> tuple[float, int] | None:
    """Pooled scatter of readings repeated at the same gauge, posture and approach
    side (the cycles): an estimate of the noise that needs no model."""
    if not obs.raw:
        return None
    group = repeat_groups(obs)
    dof = len(obs) - (group.max() + 1)
    if dof <= 0:
        return None
    means = np.bincount(group, weights=obs.values) / np.bincount(group)
    ss = float(np.sum((obs.values - means[group]) ** 2))
    return float(np.sqrt(ss / dof)), int(dof)


def noise_for(obs: Observations) -> NoiseEstimate:
    machine = obs.machine
    step = machine.gauge_resolution_mm
    rounding_var = step**2 / 12.0
    if machine.gauge_repeatability_mm is not None:
        spread, source, dof = machine.gauge_repeatability_mm, "machine file", None
    else:
        measured = pure_error(obs)
        if measured is None:
            # Tabulated deviations carry no repeats: the display step is the noise.
            return NoiseEstimate(step, "gauge resolution")
        (spread, dof), source = measured, "repeated readings"
    if spread < step / 2:
        # Too little noise to dither the display: the rounding repeats with the
        # posture, so it is added (a measured scatter cannot show it) and marked.
        return NoiseEstimate(float(np.sqrt(spread**2 + rounding_var)), source, dof, step)
    return NoiseEstimate(spread, source, dof)


def reading_covariance(obs: Observations, noise: NoiseEstimate) -> np.ndarray | None:
    """Covariance of raw readings (mm^2) when their errors are not independent (a
    repeated display rounding), else None: independent, ``sigma^2`` each."""
    if not obs.raw or noise.repeated_rounding_mm is None:
        return None
    rounding_var = noise.repeated_rounding_mm**2 / 12.0
    independent_var = max(noise.sigma_mm**2 - rounding_var, 0.0)
    group = repeat_groups(obs)
    same = group[:, None] == group[None, :]
    return independent_var * np.eye(len(obs)) + rounding_var * same
