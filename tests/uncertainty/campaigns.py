"""Campaign readings for the uncertainty tests: the papers' protocol (three legs, Zero
-> Max -> Min -> Zero, three cycles: 72 readings) simulated with the exact model,
each gauge's arbitrary zero, its scatter and its display rounding."""

from __future__ import annotations

from dataclasses import replace

from ogacq.identify.fit import FitResult, fit
from ogacq.identify.observations import Observations
from ogacq.model.machine import PAPER_PROTOTYPE
from ogacq.model.parameters import PARAM_SETS
from ogacq.protocol.plan import ProtocolConfig, planned_layout
from ogacq.sim.readings import simulated_readings

TRUTH = {"joint_offset.x": 0.42, "joint_offset.y": -0.77, "joint_offset.z": 1.10}


def papers_campaign(*, scatter_mm: float = 0.0015, step_mm: float = 0.001, seed: int = 1,
                    params: str = "offsets") -> tuple[Observations, FitResult]:
    machine = replace(PAPER_PROTOTYPE, gauge_resolution_mm=step_mm,
                      gauge_repeatability_mm=scatter_mm)
    obs = simulated_readings(machine, planned_layout(ProtocolConfig(), machine), TRUTH,
                             scatter_mm=scatter_mm, step_mm=step_mm, seed=seed)
    return obs, fit(obs, PARAM_SETS[params])
