"""Campaign readings for the uncertainty tests: the papers' protocol (three legs, Zero
-> Max -> Min -> Zero, three cycles: 72 readings) simulated with the exact model,
each gauge's arbitrary zero, its scatter and its display rounding."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ogacq.identify.fit import FitResult, fit
from ogacq.identify.observations import Observations, readings_observations
from ogacq.model.machine import PAPER_PROTOTYPE
from ogacq.model.parameters import PARAM_SETS, vector
from ogacq.protocol.plan import ProtocolConfig, planned_layout

TRUTH = {"joint_offset.x": 0.42, "joint_offset.y": -0.77, "joint_offset.z": 1.10}


def papers_campaign(*, scatter_mm: float = 0.0015, step_mm: float = 0.001, seed: int = 1,
                    params: str = "offsets") -> tuple[Observations, FitResult]:
    machine = replace(PAPER_PROTOTYPE, gauge_resolution_mm=step_mm,
                      gauge_repeatability_mm=scatter_mm)
    layout = planned_layout(ProtocolConfig(), machine)
    rng = np.random.default_rng(seed)
    clean = readings_observations(machine, layout, np.zeros(len(layout))).predict(
        vector(TRUTH))
    values = clean + rng.uniform(2, 10, layout.n_gauges)[layout.gauge] + \
        rng.normal(0, scatter_mm, len(layout))
    obs = readings_observations(machine, layout, np.round(values / step_mm) * step_mm)
    return obs, fit(obs, PARAM_SETS[params])
