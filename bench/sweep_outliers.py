"""Sweep (not a test): how often the diagnosis names a reading that disagrees with its
repeats (``diagnose/outliers.py``) where there is none, and how often it finds one
planted.

Campaigns of the papers' plan (3 cycles, 72 readings) on the bench machine, 1 um
display, gauge noise as the machine file states it (2 um) and, with the statement
removed, as measured from the repeats: clean; with a thermal drift of the joints
(steps of a few noise units per cycle, the hard case); with one reading shifted by
``SLIP_UM``. Prints the share named per case.

Run: python bench/sweep_outliers.py [seeds, default 300]
"""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_linear import MACHINE, TRUTH  # noqa: E402

from ogacq.diagnose.locate import row_labels  # noqa: E402
from ogacq.diagnose.outliers import outlying_readings  # noqa: E402
from ogacq.identify.noise import noise_for  # noqa: E402
from ogacq.identify.observations import readings_observations  # noqa: E402
from ogacq.model.parameters import vector  # noqa: E402
from ogacq.protocol.plan import ProtocolConfig, planned_layout  # noqa: E402

SLIP_UM = 30.0
DRIFT_UM_PER_H = {"none": 0.0, "drift": 40.0, "strong drift": 200.0}
LEVEL = 0.01


def values(machine, layout, seed: int, drift_um_h: float, slip: bool) -> np.ndarray:
    rng = np.random.default_rng(seed)
    clean = readings_observations(machine, layout, np.zeros(len(layout))).predict(vector(TRUTH))
    out = clean + rng.uniform(2, 10, layout.n_gauges)[layout.gauge] \
        + rng.normal(0, 0.002, len(layout)) + drift_um_h * 1e-3 * layout.t_s / 3600
    if slip:
        out[rng.integers(len(out))] += SLIP_UM * 1e-3
    return np.round(out, 3)


def main() -> None:
    seeds = int(sys.argv[1]) if len(sys.argv) > 1 else 300
    layout = planned_layout(ProtocolConfig(cycles=3), MACHINE)
    print(f"{seeds} campaigns each, 72 readings, level {LEVEL}; campaign "
          f"{layout.t_s.max() / 60:.0f} min long")
    for noise_name, machine in (("stated", MACHINE),
                                ("measured", replace(MACHINE, gauge_repeatability_mm=None))):
        for drift_name, drift in DRIFT_UM_PER_H.items():
            for slip in (False, True):
                named = 0
                for seed in range(seeds):
                    obs = readings_observations(machine, layout,
                                                values(machine, layout, seed, drift, slip))
                    found, _ = outlying_readings(obs, row_labels(obs), noise_for(obs), LEVEL)
                    named += bool(found)
                what = f"one reading {SLIP_UM:g} um off" if slip else "no slip"
                print(f"  noise {noise_name:8s} {drift_name:12s} {what:22s} "
                      f"named in {named / seeds:6.1%}")


if __name__ == "__main__":
    main()
