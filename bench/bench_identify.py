"""Benchmark of the identification engine (prints figures; not a test).

1. Nonlinear refit of a 72-reading campaign (the papers' protocol): median ms,
   beside a plain scipy.optimize.least_squares fit of the same model.
2. Monte-Carlo accuracy prediction with 10,000 trials of the full nonlinear fit,
   beside a per-trial least_squares loop (timed on a sample, scaled up).

Targets on 2 cores: refit under 20 ms; 10,000 trials under 2 s.
Run: python bench/bench_identify.py
"""

from __future__ import annotations

import statistics
import time

import numpy as np
from scipy.optimize import least_squares

from ogacq.identify.accuracy import planned_observations, predict_accuracy
from ogacq.identify.fit import fit
from ogacq.identify.observations import readings_observations
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import PARAM_SETS, indices, vector

MACHINE = MachineSpec(310.25, -100.0, 60.0, gauge_resolution_mm=0.001,
                      gauge_repeatability_mm=0.002)
TRUTH = {"joint_offset.x": 0.42, "joint_offset.y": -0.77, "joint_offset.z": 1.10}
NAMES = PARAM_SETS["offsets"]


def campaign(seed: int):
    plan = planned_observations(MACHINE, postures=("zero", "max", "min", "zero"), cycles=3)
    rng = np.random.default_rng(seed)
    values = plan.predict(vector(TRUTH)) + rng.normal(0, 0.002, len(plan))
    return readings_observations(MACHINE, plan.layout, values)


def scipy_fit(obs) -> np.ndarray:
    free = indices(NAMES)

    def residual(x):
        theta = vector()
        theta[free] = x
        return obs.remove_zeros(obs.values - obs.predict(theta))

    return least_squares(residual, np.zeros(len(free))).x


def timed(fn, repeats: int) -> list[float]:
    out = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t)
    return out


def main() -> None:
    obs = campaign(1)
    fit(obs, NAMES)  # warm caches
    ours = statistics.median(timed(lambda: fit(obs, NAMES), 50)) * 1e3
    plain = statistics.median(timed(lambda: scipy_fit(obs), 20)) * 1e3
    agree = np.max(np.abs(fit(obs, NAMES).values - scipy_fit(obs)))
    print(f"refit, 72 readings, offsets: {ours:.2f} ms median "
          f"(target < 20 ms) | scipy least_squares {plain:.2f} ms | ratio {plain / ours:.1f}x "
          f"| estimates agree to {agree:.1e} mm")

    plan = planned_observations(MACHINE, postures=("zero", "max", "min", "zero"), cycles=3)
    t = time.perf_counter()
    pred = predict_accuracy(plan, NAMES, 0.002, truth=TRUTH, trials=10_000, seed=0,
                            rounding_mm=0.001)
    mc_s = time.perf_counter() - t
    sample = 200
    rng = np.random.default_rng(0)
    clean = plan.predict(vector(TRUTH))

    def loop():
        for _ in range(sample):
            y = np.round((clean + rng.normal(0, 0.002, len(clean))) / 0.001) * 0.001
            scipy_fit(readings_observations(MACHINE, plan.layout, y))

    per_trial = timed(loop, 1)[0] / sample
    loop_s = per_trial * 10_000
    print(f"Monte-Carlo, 10,000 nonlinear fits: {mc_s:.2f} s (target < 2 s) | "
          f"per-trial least_squares loop {loop_s:.1f} s (from {sample} trials) | "
          f"ratio {loop_s / mc_s:.0f}x | std MC/analytic "
          f"{np.mean(pred.mc_std / pred.analytic_std):.3f}")


if __name__ == "__main__":
    main()
