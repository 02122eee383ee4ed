"""Benchmark: the GUM budget against its Monte-Carlo check (prints figures; not a test).

The papers' protocol (three legs, Zero -> Max -> Min -> Zero, three cycles: 72
readings) simulated with the exact model for two stations: 1 um digital
indicators and the papers' 10 um dials (whose repeats share their rounding). All
sources evaluated: gauge scatter, display resolution, each gauge's certificate
(U = 3 um, k = 2), the temperature (20.4 -> 23.6 degC, thermometer u 0.3 degC,
steel legs) and the register rounding of a 0.01 mm offset step. For each
parameter set the budget's u_c beside the Monte-Carlo's (JCGM 101:2008) std, their
ratio with its standard error, the 95 % intervals, and the time of 20,000 refits.

Target: every ratio within 10 % of 1 (docs/calibration-record.md section 3);
20,000 draws in a few seconds on 2 cores.
Run: python bench/bench_budget.py [draws]
"""

from __future__ import annotations

import sys
import time
from dataclasses import replace

from ogacq.identify.fit import fit
from ogacq.model.machine import PAPER_PROTOTYPE
from ogacq.model.parameters import PARAM_SETS
from ogacq.protocol.plan import ProtocolConfig, planned_layout
from ogacq.sim.readings import simulated_readings
from ogacq.uncertainty.budget import uncertainty_budget
from ogacq.uncertainty.inputs import BudgetInputs, standard_uncertainty
from ogacq.uncertainty.montecarlo import monte_carlo

TRUTH = {"joint_offset.x": 0.42, "joint_offset.y": -0.77, "joint_offset.z": 1.10}
GAUGES = ("y_x", "z_x", "x_y", "z_y", "x_z", "y_z")


def campaign(scatter_mm: float, step_mm: float, seed: int = 1):
    machine = replace(PAPER_PROTOTYPE, gauge_resolution_mm=step_mm,
                      gauge_repeatability_mm=scatter_mm)
    return simulated_readings(machine, planned_layout(ProtocolConfig(), machine), TRUTH,
                              scatter_mm=scatter_mm, step_mm=step_mm, seed=seed)


def main() -> None:
    draws = int(sys.argv[1]) if len(sys.argv) > 1 else 20_000
    for label, scatter, step in (("1 um digital indicators", 0.0015, 0.001),
                                 ("10 um dials (papers)", 0.002, 0.01)):
        obs = campaign(scatter, step)
        for params in ("offsets", "both"):
            result = fit(obs, PARAM_SETS[params])
            inputs = BudgetInputs.from_fit(
                result, calibration_u_mm={g: standard_uncertainty(0.003, 2.0) for g in GAUGES},
                ambient_start_c=20.4, ambient_end_c=23.6, register_step_mm=0.01)
            start = time.perf_counter()
            budget = uncertainty_budget(obs, result, inputs)
            budget_ms = (time.perf_counter() - start) * 1e3
            mc = monte_carlo(obs, result, inputs, draws=draws, seed=2026, budget=budget)
            print(f"\n{label}, {len(obs)} readings, {params}: budget {budget_ms:.1f} ms, "
                  f"{draws} draws {mc.seconds:.2f} s, converged {mc.converged_fraction:.1%}, "
                  f"agrees within 10 %: {mc.agrees()}"
                  + ("" if budget.complete else "; budget incomplete: "
                     + "; ".join(sorted({o.note for o in budget.outputs if o.note}))))
            print(f"  {'parameter':<16}{'u_c GUM':>11}{'u MC':>11}{'ratio':>8}{'se':>7}"
                  f"{'GUM 95 %':>24}{'MC 95 %':>24}")
            for k, out in enumerate(budget.outputs):
                centre = out.value_mm + (out.temperature_correction_mm or 0.0)
                gum = f"[{centre - out.U:+.4f}, {centre + out.U:+.4f}]"
                mcs = f"[{mc.low[k]:+.4f}, {mc.high[k]:+.4f}]"
                print(f"  {out.name:<16}{out.u_c * 1e3:>9.3f}um{mc.std[k] * 1e3:>9.3f}um"
                      f"{mc.ratio[k]:>8.3f}{mc.ratio_se[k]:>7.3f}{gum:>24}{mcs:>24}")


if __name__ == "__main__":
    main()
