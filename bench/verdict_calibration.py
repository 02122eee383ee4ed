"""Calibrate the consistency test: false-alarm rate per regime, and power.

    python bench/verdict_calibration.py [--seeds 200] [--power-seeds 100] [--workers 2]
    python bench/verdict_calibration.py --maps [--seeds 200] [--scan-seeds 40]

Prints, for every cell of the grid (display step x gauge noise x noise stated or
measured from repeats x protocol x geometry), the rate at which control campaigns
(joint offsets only) are called inconsistent, its exact binomial 95 % interval,
and whether the interval contains or lies below the nominal level. Then the
power on a few concealed effects. Exit 1 when a cell's interval lies above the
nominal level.

``--maps``: the same controls through the whole diagnosis, which searches the
residuals for error maps along the axes and in time after the verdict: an alarm
is then the verdict's or a map named, and every cell must keep its rate. The grid
gains scans (every 4 mm both ways, two cycles: each axis read at 41 positions, so
every family is searched), at ``--scan-seeds`` a cell. Prints per cell the alarms,
the maps named where the verdict was within the noise (what the search adds), and
the rate with its interval.
"""

from __future__ import annotations

import argparse
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from ogacq.diagnose.diagnosis import diagnose  # noqa: E402
from ogacq.identify.consistency import LEVEL  # noqa: E402
from ogacq.identify.verdict_calibration import (  # noqa: E402
    Cell,
    Rate,
    alarm_rate,
    grid,
    seeds_of,
    simulated_observations,
)
from ogacq.protocol.plan import ProtocolConfig, planned_layout  # noqa: E402

SCAN = ProtocolConfig(scan_step_mm=4.0, cycles=2)

POWER_EFFECTS = ({"squareness.xy": 0.5}, {"axis_offset.xz": 0.05}, {"backlash.x": 0.008})
POWER_CELLS = grid(noises=(0.001, 0.002), geometries=("prototype",))


def _run(job: tuple[Cell, int, dict | None]):
    cell, seeds, effects = job
    return cell, effects, alarm_rate(cell, seeds_of(cell, seeds), effects)


def _maps_run(job: tuple[Cell, int, bool]) -> tuple[Cell, bool, Rate, int]:
    """Control campaigns of ``cell`` (a scan instead of its protocol when ``scan``)
    through the whole diagnosis: (cell, scan, alarms, maps named beside a verdict
    within the noise)."""
    cell, seeds, scan = job
    lay = planned_layout(SCAN, cell.machine()) if scan else cell.layout()
    hits = added = 0
    for seed in seeds_of(cell, seeds, first=500_000 if scan else 0):
        d = diagnose(simulated_observations(cell, seed, None, lay), separate=False)
        named = bool(d.map_effects)
        hits += d.base.state == "inconsistent" or named
        added += named and d.base.consistent
    return cell, scan, Rate(hits, seeds), added


def maps_main(args) -> int:
    start = time.perf_counter()
    cells = grid()
    scans = grid(protocols=("papers",))  # the scan replaces the protocol: once per regime
    jobs = [(c, args.seeds, False) for c in cells] + [(c, args.scan_seeds, True) for c in scans]
    with ProcessPoolExecutor(args.workers) as pool:
        results = list(pool.map(_maps_run, jobs, chunksize=1))
    print(f"False alarms of control campaigns through the whole diagnosis (verdict, then "
          f"the map search), nominal level {LEVEL:g}; {args.seeds} seeds a cell, scans "
          f"{args.scan_seeds}")
    print("display  noise    source    protocol    geometry   alarms  maps  rate    "
          "95 % interval")
    failed, maps_named, total = 0, 0, 0
    for cell, scan, rate, added in results:
        low, high = rate.interval()
        ok = low <= LEVEL
        failed += not ok
        maps_named += added
        total += rate.trials
        label = cell.label().replace(f"{cell.protocol:<10}", f"{'scan 4 mm':<10}") if scan \
            else cell.label()
        print(f"{label}  {rate.hits:>6}  {added:>4}  {rate.value:.3f}  [{low:.3f}, {high:.3f}]"
              f"  {'ok' if ok else 'ABOVE NOMINAL'}")
    print(f"{len(results) - failed} of {len(results)} cells contain or lie below the nominal "
          f"level; maps named beside a verdict within the noise: {maps_named} in {total} "
          f"campaigns; {time.perf_counter() - start:.0f} s")
    return 1 if failed else 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=200)
    parser.add_argument("--power-seeds", type=int, default=100)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--maps", action="store_true",
                        help="the controls through the whole diagnosis, map search included")
    parser.add_argument("--scan-seeds", type=int, default=40)
    args = parser.parse_args()
    if args.maps:
        return maps_main(args)
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
