"""The gauge noise a fit is judged against: stated, measured from repeats, or the
display step. Never the misfit itself, which would call any model consistent."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ogacq.identify.observations import Observations


@dataclass(frozen=True)
class NoiseEstimate:
    sigma_mm: float
    source: str  # "machine file", "repeated readings", "gauge resolution"
    dof: int | None = None  # degrees of freedom of a measured estimate

    def describe(self) -> str:
        extra = f", {self.dof} dof" if self.dof else ""
        return f"{self.sigma_mm:.4g} mm ({self.source}{extra})"


def pure_error(obs: Observations) -> tuple[float, int] | None:
    """Pooled scatter of readings repeated at the same gauge, posture and approach
    side (the cycles): an estimate of the noise that needs no model."""
    if not obs.raw:
        return None
    lay = obs.layout
    keys = np.column_stack([lay.gauge, np.round(lay.q_mm, 6), lay.approach])
    _, group = np.unique(keys, axis=0, return_inverse=True)
    group = group.ravel()
    n_groups = group.max() + 1
    dof = len(obs) - n_groups
    if dof <= 0:
        return None
    means = np.bincount(group, weights=obs.values) / np.bincount(group)
    ss = float(np.sum((obs.values - means[group]) ** 2))
    return float(np.sqrt(ss / dof)), int(dof)


def noise_for(obs: Observations) -> NoiseEstimate:
    machine = obs.machine
    if machine.gauge_repeatability_mm is not None:
        return NoiseEstimate(machine.gauge_repeatability_mm, "machine file")
    measured = pure_error(obs)
    # A display step bounds how small the scatter can look: identical repeats
    # mean "below one step", not "no noise".
    floor = machine.gauge_resolution_mm / np.sqrt(12.0)
    if measured is not None:
        return NoiseEstimate(max(measured[0], floor), "repeated readings", measured[1])
    return NoiseEstimate(machine.gauge_resolution_mm, "gauge resolution")
