"""Calibrate the consistency test: false-alarm rate per regime, and power.

    python bench/verdict_calibration.py [--seeds 200] [--power-seeds 100] [--workers 2]

Prints, for every cell of the grid (display step x gauge noise x noise stated or
measured from repeats x protocol x geometry), the rate at which control campaigns
(joint offsets only) are called inconsistent, its exact binomial 95 % interval,
and whether the interval contains or lies below the nominal level. Then the
power on a few concealed effects. Exit 1 when a cell's interval lies above the
nominal level.
"""

from __future__ import annotations

import argparse
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from ogacq.identify.consistency import LEVEL  # noqa: E402
from ogacq.identify.verdict_calibration import Cell, alarm_rate, grid, seeds_of  # noqa: E402

POWER_EFFECTS = ({"squareness.xy": 0.5}, {"axis_offset.xz": 0.05}, {"backlash.x": 0.008})
POWER_CELLS = grid(noises=(0.001, 0.002), geometries=("prototype",))


def _run(job: tuple[Cell, int, dict | None]):
    cell, seeds, effects = job
    return cell, effects, alarm_rate(cell, seeds_of(cell, seeds), effects)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=200)
    parser.add_argument("--power-seeds", type=int, default=100)
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    start = time.perf_counter()
    controls = [(cell, args.seeds, None) for cell in grid()]
    power = [(cell, args.power_seeds, e) for e in POWER_EFFECTS for cell in POWER_CELLS]
    with ProcessPoolExecutor(args.workers) as pool:
        results = list(pool.map(_run, controls + power, chunksize=1))

    print(f"False alarms of control campaigns (joint offsets only), nominal level {LEVEL:g}, "
          f"{args.seeds} seeds a cell")
    print("display  noise    source    protocol    geometry   rate    95 % interval     ")
    failed = 0
    for cell, _, rate in results[:len(controls)]:
        low, high = rate.interval()
        ok = low <= LEVEL
        failed += not ok
        print(f"{cell.label()}  {rate.value:.3f}  [{low:.3f}, {high:.3f}]  "
              f"{'ok' if ok else 'ABOVE NOMINAL'}")
    print(f"{len(controls) - failed} of {len(controls)} cells contain or lie below the "
          f"nominal level")
    print(f"\nPower on concealed effects, {args.power_seeds} seeds a cell")
    for cell, effects, rate in results[len(controls):]:
        low, high = rate.interval()
        what = ", ".join(f"{k} = {v:g}" for k, v in effects.items())
        print(f"{cell.label()}  {what:<22} {rate.value:.2f}  [{low:.2f}, {high:.2f}]")
    print(f"\n{sum(r.trials for *_, r in results)} campaigns in "
          f"{time.perf_counter() - start:.0f} s")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
