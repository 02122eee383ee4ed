"""Benchmark: the diagnosis of a dense scan beside the same number of readings at a
1 mm step, in one run (prints figures; not a test).

Issue 37 item 9: a scan of 72,000 readings at a 0.027 mm step took 537 s CPU and
703 MB in ``diagnose`` while the same readings at a 1 mm step (37 cycles of 1,938
readings) took 6.8 s: the periodogram summed over every reading, at pitches down to
2.5 steps. Both scans are made here with the simulator as ``bench_diagnose_maps.py``
makes its scan (every leg up and down, ``ProtocolConfig.scan_step_mm``; a cyclic
error of 5 um and 5 mm pitch on the x screw, 2 um gauge scatter on a 1 um display):

- ``1 mm``: a 1 mm step, cycles repeated to the size (the reference);
- ``dense``: one cycle at the step that gives the same number of readings.

For each: CPU seconds of ``diagnose`` (the least of three warm runs), peak traced memory (a second
run under tracemalloc, which numpy's arrays report to), what was found; then the
ratio dense / 1 mm. Target: the ratio <= 2, the dense scan < 10 s and < 500 MiB.
Run: python bench/bench_mapsearch_scale.py [readings, default 72000]

The BLAS runs on one thread, as ``ogacq diagnose`` runs it (``ogacq/cli/app.py``:
``OPENBLAS_NUM_THREADS``, unless set), so that the CPU seconds are the command's and not
those of a second BLAS thread spinning beside the first; set the variable to compare.
"""

from __future__ import annotations

import math
import os
import sys

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy is imported
import time
from functools import partial
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_diagnose_maps import SCAN_CYCLE, found  # noqa: E402
from bench_linear import MACHINE, TRUTH, peak_mib  # noqa: E402

from ogacq.diagnose.diagnosis import diagnose  # noqa: E402
from ogacq.identify.observations import Observations  # noqa: E402
from ogacq.model.parameters import vector  # noqa: E402
from ogacq.protocol.plan import ProtocolConfig, planned_layout  # noqa: E402
from ogacq.sim.readings import simulated_readings  # noqa: E402
from ogacq.sim.truth import LeadScrewError, SimTruth  # noqa: E402

REPEATS = 3


def scan(step_mm: float, cycles: int, seed: int = 1) -> Observations:
    layout = planned_layout(ProtocolConfig(scan_step_mm=step_mm, cycles=cycles), MACHINE)
    truth = SimTruth(vector({k: v for k, v in TRUTH.items() if k.startswith("joint_offset")}),
                     lead_screw={0: LeadScrewError(0.005, 5.0, 30.0)})
    return simulated_readings(MACHINE, layout, truth, scatter_mm=0.002, step_mm=0.001,
                              seed=seed)


def cpu_seconds(obs: Observations, repeats: int = REPEATS) -> tuple[float, object]:
    """The least CPU time of ``repeats`` diagnoses (a machine shared with other work
    slows some runs, never speeds one up) and the diagnosis."""
    best = math.inf
    for _ in range(repeats):
        start = time.process_time()
        d = diagnose(obs)
        best = min(best, time.process_time() - start)
    return best, d


def main() -> None:
    readings = int(sys.argv[1]) if len(sys.argv) > 1 else 72_000
    cycles = max(1, round(readings / SCAN_CYCLE))
    dense_step = round(SCAN_CYCLE / readings, 4)  # one cycle of about as many readings
    diagnose(scan(1.0, 1))  # warm caches
    print(f"{'scan':>6} {'step mm':>8} {'cycles':>6} {'readings':>9} | {'CPU s':>7} "
          f"{'peak MiB':>9} | found")
    rows = {}
    for name, step, n_cycles in (("1 mm", 1.0, cycles), ("dense", dense_step, 1)):
        obs = scan(step, n_cycles)
        cpu, d = cpu_seconds(obs)
        mib = peak_mib(partial(diagnose, obs))
        rows[name] = (cpu, mib)
        print(f"{name:>6} {step:>8.4g} {n_cycles:>6} {len(obs):>9,} | {cpu:>7.2f} {mib:>9.1f} "
              f"| {found(d)}; final {'within' if d.final.consistent else 'NOT within'} "
              "the noise")
    (ref_s, ref_mib), (dense_s, dense_mib) = rows["1 mm"], rows["dense"]
    print(f"BLAS threads: {os.environ['OPENBLAS_NUM_THREADS']}; "
          f"dense / 1 mm: CPU {dense_s / ref_s:.2f}x, memory {dense_mib / ref_mib:.2f}x "
          "(targets: <= 2x, < 10 s, < 500 MiB)")


if __name__ == "__main__":
    main()
