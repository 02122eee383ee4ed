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


def simulated_readings(machine: MachineSpec, layout: ReadingsLayout,
                       truth: Mapping[str, float], *, scatter_mm: float, step_mm: float,
                       seed: int) -> Observations:
    rng = np.random.default_rng(seed)
    clean = readings_observations(machine, layout, np.zeros(len(layout))).predict(
        vector(truth))
    values = clean + rng.uniform(2, 10, layout.n_gauges)[layout.gauge] + \
        rng.normal(0, scatter_mm, len(layout))
    return readings_observations(machine, layout, np.round(values / step_mm) * step_mm)
