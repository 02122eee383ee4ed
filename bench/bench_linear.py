"""Benchmark: is every analysis linear in the readings? (prints figures; not a test)

Campaigns of the papers' plan repeated 3 to 3,000 cycles (72 to 72,000 readings), two
concealed effects. For each size, in this one run:
- refit (library, joint offsets) beside a plain numpy Gauss-Newton floor
  (``numpy_floor.py``: closed-form nominal model, analytic Jacobian, the same
  weighting) fitting the same readings, and how far their offsets differ;
- diagnose (library, every effect alone and in pairs), beside the refit of the same
  readings;
- peak memory of each (tracemalloc, in a second run so that tracing does not slow
  the timed one);
then the growth exponents from 720 to 72,000 readings (1.0 is linear).

Targets (issue 14, 2 cores): 72,000 readings refit < 2 s, diagnose < 10 s, both
< 500 MiB; exponents <= 1.1; the fit within 1.5x of the floor at 72 readings.
Run: python bench/bench_linear.py [largest size]
"""

from __future__ import annotations

import math
import statistics
import sys
import time
import tracemalloc
from collections.abc import Callable
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from numpy_floor import OffsetsFloor  # noqa: E402

from ogacq.diagnose.diagnosis import diagnose  # noqa: E402
from ogacq.identify.fit import fit  # noqa: E402
from ogacq.identify.noise import noise_for  # noqa: E402
from ogacq.identify.observations import Observations, readings_observations  # noqa: E402
from ogacq.model.machine import MachineSpec  # noqa: E402
from ogacq.model.parameters import PARAM_SETS, vector  # noqa: E402
from ogacq.protocol.plan import ProtocolConfig, planned_layout  # noqa: E402

MACHINE = MachineSpec(310.25, -100.0, 60.0, gauge_resolution_mm=0.001,
                      gauge_repeatability_mm=0.002)
TRUTH = {"joint_offset.x": -0.49, "joint_offset.y": 0.50, "joint_offset.z": -1.67,
         "squareness.xy": 0.4, "backlash.z": 0.02}
SIZES = (72, 720, 7_200, 72_000)
OFFSETS = PARAM_SETS["offsets"]


def campaign(n_readings: int, seed: int = 1) -> Observations:
    """The papers' plan (24 readings a cycle) repeated, rounded to the 1 um display."""
    layout = planned_layout(ProtocolConfig(cycles=n_readings // 24), MACHINE)
    rng = np.random.default_rng(seed)
    clean = readings_observations(MACHINE, layout, np.zeros(len(layout))).predict(
        vector(TRUTH))
    values = clean + rng.uniform(2, 10, layout.n_gauges)[layout.gauge] \
        + rng.normal(0, 0.002, len(layout))
    return readings_observations(MACHINE, layout, np.round(values, 3))


def floor_of(obs: Observations) -> OffsetsFloor:
    """The floor's inputs: the layout's arrays and the same noise model's numbers."""
    lay, noise = obs.layout, noise_for(obs)
    return OffsetsFloor(lay.q_mm, lay.leg, lay.gauge_axis, lay.gauge, lay.setting_q_mm,
                        lay.repeat_group, obs.values, MACHINE.leg_length_mm,
                        noise.within_var, noise.shared_var, noise.variance)


def seconds(fn: Callable[[], object], repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def peak_mib(fn: Callable[[], object]) -> float:
    tracemalloc.start()
    fn()
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return peak / 2**20


def exponent(sizes: list[int], values: list[float], lo: int, hi: int) -> float:
    a, b = sizes.index(lo), sizes.index(hi)
    return math.log(values[b] / values[a]) / math.log(hi / lo)


def main() -> None:
    largest = int(sys.argv[1]) if len(sys.argv) > 1 else SIZES[-1]
    sizes = [n for n in SIZES if n <= largest]
    rows = {k: [] for k in ("refit_s", "refit_mib", "diag_s", "diag_mib")}
    fit(campaign(72), OFFSETS)  # warm caches
    print(f"{'readings':>9} | {'refit':>9} {'numpy floor':>11} {'ratio':>5} {'|diff| mm':>9}"
          f" {'peak':>9} | {'diagnose':>9} {'/refit':>6} {'peak':>9} | found")
    for n in sizes:
        obs = campaign(n)
        repeats = 20 if n <= 720 else 3 if n <= 7_200 else 1
        refit_s = seconds(lambda obs=obs: fit(obs, OFFSETS), repeats)
        floor = floor_of(obs)
        floor_s = seconds(floor.fit, repeats)
        diff = float(np.max(np.abs(fit(obs, OFFSETS).values - floor.fit())))
        refit_mib = peak_mib(lambda obs=obs: fit(obs, OFFSETS))
        start = time.perf_counter()
        found = diagnose(obs)
        diag_s = time.perf_counter() - start
        diag_mib = peak_mib(lambda obs=obs: diagnose(obs))
        for key, value in zip(rows, (refit_s, refit_mib, diag_s, diag_mib), strict=True):
            rows[key].append(value)
        steps = " then ".join(s.label for s in found.selection.steps) or "nothing"
        print(f"{n:>9,} | {refit_s * 1e3:>7.1f}ms {floor_s * 1e3:>9.1f}ms "
              f"{refit_s / floor_s:>5.2f} {diff:>9.1e} {refit_mib:>5.0f} MiB | "
              f"{diag_s:>8.2f}s {diag_s / refit_s:>6.0f} {diag_mib:>5.0f} MiB | {steps}")
    if 720 in sizes and sizes[-1] > 720:
        hi = sizes[-1]
        print(f"growth exponents 720 -> {hi:,} (target <= 1.1): refit time "
              f"{exponent(sizes, rows['refit_s'], 720, hi):.2f}, memory "
              f"{exponent(sizes, rows['refit_mib'], 720, hi):.2f}; diagnose time "
              f"{exponent(sizes, rows['diag_s'], 720, hi):.2f}, memory "
              f"{exponent(sizes, rows['diag_mib'], 720, hi):.2f}")
    if sizes[-1] == 72_000:
        print(f"72,000 readings (targets refit < 2 s, diagnose < 10 s, both < 500 MiB): "
              f"refit {rows['refit_s'][-1]:.2f} s {rows['refit_mib'][-1]:.0f} MiB, "
              f"diagnose {rows['diag_s'][-1]:.2f} s {rows['diag_mib'][-1]:.0f} MiB")


if __name__ == "__main__":
    main()
