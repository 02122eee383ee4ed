"""A planned campaign's readings without devices: the model's prediction at a stated
truth, each gauge set at an arbitrary zero, the gauges' scatter, rounded to the
display step. Benchmarks and tests draw their campaigns from here, so theirs are the
same campaign."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ogacq.identify.observations import Observations, ReadingsLayout, readings_observations
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import vector
from ogacq.sim.physics import true_coordinates
from ogacq.sim.truth import SimTruth


def simulated_readings(machine: MachineSpec, layout: ReadingsLayout,
                       truth: Mapping[str, float] | SimTruth, *, scatter_mm: float,
                       step_mm: float, seed: int) -> Observations:
    """``truth``: the library's effects by name, or a whole simulated truth (the axes'
    errors beyond the library included; its own noise is not used: ``scatter_mm``)."""
    rng = np.random.default_rng(seed)
    whole = truth if isinstance(truth, SimTruth) else SimTruth(vector(truth))
    clean = true_coordinates(whole, layout, machine)
    values = clean + rng.uniform(2, 10, layout.n_gauges)[layout.gauge] + \
        rng.normal(0, scatter_mm, len(layout))
    return readings_observations(machine, layout, np.round(values / step_mm) * step_mm)
