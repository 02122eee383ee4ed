"""Benchmark: the diagnosis with the search for error maps beside the library-only
diagnosis, at 72, 7,200 and 72,000 readings, in one run (prints figures; not a test).

Two campaigns at each size:
- the papers' plan repeated (bench_linear's campaign: squareness and a backlash
  concealed), where no axis is read densely enough for a map along q: the search
  looks at time only, and the library's effects are set beside the maps that could
  take their place;
- a scan of every leg (1 mm steps up and down, cycles repeated to the size) with a
  cyclic error of 5 um and 5 mm pitch on the x screw: the periodogram, the spline,
  the hysteresis and the bows on every axis, the refit with the map found.
For each: seconds with the maps (``diagnose``) and without (``maps=False``), their
ratio, what was found; then the growth exponents from 7,200 to 72,000 readings (1.0
is linear).

Target (issue 23): the map search near linear in the readings; 72,000-reading
diagnosis was 3.2 s on 2 cores before the maps.
Run: python bench/bench_diagnose_maps.py [largest size]
"""

from __future__ import annotations

import math
import sys
import time
from functools import partial
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_linear import MACHINE, TRUTH, campaign, seconds  # noqa: E402

from ogacq.diagnose.diagnosis import diagnose  # noqa: E402
from ogacq.identify.observations import Observations  # noqa: E402
from ogacq.model.parameters import vector  # noqa: E402
from ogacq.protocol.plan import ProtocolConfig, planned_layout  # noqa: E402
from ogacq.sim.readings import simulated_readings  # noqa: E402
from ogacq.sim.truth import LeadScrewError, SimTruth  # noqa: E402

SIZES = (72, 7_200, 72_000)
SCAN_CYCLE = 1_938  # readings of one cycle of a 1 mm scan, three legs, up and down


def scan(n_readings: int, seed: int = 1) -> Observations:
    cycles = max(1, round(n_readings / SCAN_CYCLE))
    layout = planned_layout(ProtocolConfig(scan_step_mm=1.0, cycles=cycles), MACHINE)
    truth = SimTruth(vector({k: v for k, v in TRUTH.items() if k.startswith("joint_offset")}),
                     lead_screw={0: LeadScrewError(0.005, 5.0, 30.0)})
    return simulated_readings(MACHINE, layout, truth, scatter_mm=0.002, step_mm=0.001,
                              seed=seed)


def found(d) -> str:
    parts = [e.name for e in d.effects]
    for e in d.map_effects:
        extra = e.value.extra
        if "pitch_mm" in extra:
            parts[parts.index(e.name)] += (f" (pitch {extra['pitch_mm']:.3f} mm, "
                                           f"{e.value.value * 1e3:.2f} um)")
    return ", ".join(parts) or "nothing"


def main() -> None:
    largest = int(sys.argv[1]) if len(sys.argv) > 1 else SIZES[-1]
    sizes = [n for n in SIZES if n <= largest]
    diagnose(campaign(72))  # warm caches
    print(f"{'campaign':>8} {'readings':>9} | {'library only':>12} {'with maps':>10} "
          f"{'ratio':>6} | found (with maps)")
    times: dict[str, list[float]] = {"papers": [], "scan": []}
    counts: dict[str, list[int]] = {"papers": [], "scan": []}
    for n in sizes:
        for kind, make in (("papers", campaign), ("scan", scan)):
            obs = make(n)
            repeats = 5 if len(obs) <= 2_000 else 2 if len(obs) <= 10_000 else 1
            without = seconds(partial(diagnose, obs, maps=False), repeats)
            start = time.perf_counter()
            d = diagnose(obs)
            first = time.perf_counter() - start
            with_maps = min(first, seconds(partial(diagnose, obs), repeats - 1)) \
                if repeats > 1 else first
            times[kind].append(with_maps)
            counts[kind].append(len(obs))
            print(f"{kind:>8} {len(obs):>9,} | {without:>10.2f} s {with_maps:>8.2f} s "
                  f"{with_maps / without:>6.2f} | {found(d)}; final "
                  f"{'within' if d.final.consistent else 'NOT within'} the noise")
    for kind in times:
        if len(times[kind]) >= 2 and counts[kind][-1] > counts[kind][-2]:
            growth = math.log(times[kind][-1] / times[kind][-2]) / math.log(
                counts[kind][-1] / counts[kind][-2])
            print(f"{kind}: growth exponent {counts[kind][-2]:,} -> {counts[kind][-1]:,} "
                  f"readings {growth:.2f} (1.0 is linear)")


if __name__ == "__main__":
    main()
