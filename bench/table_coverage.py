"""Benchmark: are the compensation tables' uncertainties honest? Over many simulated
seeds (prints figures; not a test).

Each seed: a machine with joint offsets and a lead screw's cyclic error on one axis
(random axis, amplitude 2-6 µm, pitch 5-25 mm, phase), sometimes a smooth screw error on
another; a scan of every leg every 1 mm up and down (one cycle, gauge noise 0.5 µm,
display 0.1 µm); the diagnosis and its maps over the travel (zero at 0, as calibrate
tabulates them); every table format exported (``compensation.export``: only where
better than no table). Then a validation at positions other than those identified
from (uniform random over the travel, both directions): the table's correction as the
controller applies it (``AxisTable.applied``) against the simulator's truth, relative
to the reference (the constant is the joint offset's), and the same error as a
validation would measure it (plus one gauge reading's noise). Printed per format: the
share of validation positions whose error lies within the table's U (k = 2: the
map's at the position plus what the table's grid leaves of the map, as the table
states it, ``AxisTable.u_mm``), for the truth and for the measured error against U
combined with the reading's own (k = 2) (target >= 95 %); axes written / left out;
the rms error left against before.

Run: python bench/table_coverage.py [seeds, default 100]
"""

from __future__ import annotations

import sys
import tempfile
import time
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ogacq.compensation.export import export_tables
from ogacq.compensation.formats import TABLE_FORMATS
from ogacq.diagnose.diagnosis import diagnose
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import AXES, vector
from ogacq.protocol.plan import ProtocolConfig, planned_layout
from ogacq.sim.readings import simulated_readings
from ogacq.sim.truth import LeadScrewError, ScrewMap, SimTruth

MACHINE = MachineSpec(310.25, -100.0, 60.0, gauge_resolution_mm=0.0001)
NOISE_MM = 0.0005
VALIDATION_POSITIONS = 20  # per axis and direction
PITCH_MM = (4.0, 12.0)
SMOOTH_SHARE = 0.3  # seeds with a smooth screw error on another axis too
CYCLES = 2  # as calibrate's separating scan (calibration/setup.py SCAN_CYCLES)
K = 2.0


@dataclass
class Tally:
    positions: int = 0
    within_truth: int = 0
    within_measured: int = 0
    written: int = 0
    left_out: int = 0
    before_sq: list[float] = field(default_factory=list)
    after_sq: list[float] = field(default_factory=list)
    reasons: list[str] = field(default_factory=list)


tallies_by_family: dict[str, Tally] = defaultdict(Tally)  # every format's validations


def truth_of(rng: np.random.Generator) -> SimTruth:
    offsets = {f"joint_offset.{a}": float(rng.uniform(-0.5, 0.5)) for a in AXES}
    cyclic = int(rng.integers(3))
    lead = {cyclic: LeadScrewError(float(rng.uniform(0.002, 0.006)),
                                   float(rng.uniform(PITCH_MM[0], PITCH_MM[1])),
                                   float(rng.uniform(0, 360)))}
    smooth = {}
    if rng.random() < SMOOTH_SHARE:
        other = (cyclic + 1 + int(rng.integers(2))) % 3
        smooth = {other: ScrewMap((float(rng.uniform(-0.004, 0.004)),
                                   float(rng.uniform(-0.004, 0.004))))}
    return SimTruth(vector(offsets), NOISE_MM, lead, screw_map=smooth)


def true_error_mm(truth: SimTruth, axis: int, q: np.ndarray) -> np.ndarray:
    """Actual minus commanded along the joint, less its value at the reference (0)."""
    grid = np.zeros((len(q) + 1, 3))
    grid[:-1, axis] = q
    moved = truth.disturbed_q(grid)[:, axis] - grid[:, axis]
    return moved[:-1] - moved[-1]


def one_seed(seed: int, tallies: dict[str, Tally], folder: Path) -> bool:
    rng = np.random.default_rng(seed)
    truth = truth_of(rng)
    layout = planned_layout(ProtocolConfig(scan_step_mm=1.0, cycles=CYCLES, approach="both",
                                           postures=()), MACHINE)
    obs = simulated_readings(MACHINE, layout, truth, scatter_mm=NOISE_MM,
                             step_mm=MACHINE.gauge_resolution_mm, seed=seed)
    d = diagnose(obs)
    span = (MACHINE.rho_min_mm, MACHINE.rho_max_mm)
    maps = {m.axis: m for m in d.maps_over(dict.fromkeys(AXES, span), dict.fromkeys(AXES, 0.0))}
    if not maps:
        return False
    out = export_tables(folder / f"s{seed}", maps, title=f"seed {seed}")
    variant: dict[str, int] = defaultdict(int)  # FANUC's second set of options
    for e in out:
        options = TABLE_FORMATS[e.format].options[variant[e.format]]
        variant[e.format] += 1
        name = e.format + (f"#{variant[e.format]}" if len(TABLE_FORMATS[e.format].options) > 1
                           else "")
        tally = tallies[name]
        for verdict in e.axes.values():
            if not verdict.written:
                tally.left_out += 1
                tally.reasons.append(verdict.reason or "")
                continue
            tally.written += 1
        written = {a: m for a, m in maps.items() if e.axes[a].written}
        if not written:
            continue
        _validate(e.format, written, options, truth, rng, tally)
    return True


def _validate(name, written, options, truth, rng, tally: Tally) -> None:
    fmt = TABLE_FORMATS[name]
    (tables,) = fmt.tables(written, "validation", options)
    for axis, table in tables.axes.items():
        m = table.axis_map
        i = AXES.index(axis)
        family = tallies_by_family[m.source.split(",")[0].split(" (")[0]]
        q = rng.uniform(m.positions_mm[0], m.positions_mm[-1], VALIDATION_POSITIONS)
        for side in (1, -1):
            error = true_error_mm(truth, i, q)
            residual = error - table.applied(q, side)
            u_table = table.u_mm(q, side)
            measured = residual + rng.normal(0.0, NOISE_MM, len(q))
            for t in (tally, family):
                t.positions += len(q)
                t.within_truth += int(np.sum(np.abs(residual) <= u_table))
                # the measured error also holds the validation reading's own noise
                t.within_measured += int(np.sum(np.abs(measured)
                                                <= np.hypot(u_table, K * NOISE_MM)))
                t.before_sq += list(error ** 2)
                t.after_sq += list(residual ** 2)


def main() -> None:
    seeds = int(sys.argv[1]) if len(sys.argv) > 1 else 100
    tallies: dict[str, Tally] = defaultdict(Tally)
    start = time.perf_counter()
    mapped = 0
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(seeds):
            mapped += one_seed(seed, tallies, Path(tmp))
    print(f"{seeds} seeds ({mapped} with maps) in {time.perf_counter() - start:.0f} s; "
          f"validation at {VALIDATION_POSITIONS} random positions per axis and direction, "
          f"gauge noise {NOISE_MM * 1e3:g} µm; U: k = {K:g}, the table's (its map's U at the "
          "position plus what its grid leaves of the map)")
    print(f"{'format':>9} | {'axes written':>12} {'left out':>8} | {'positions':>9} "
          f"{'truth within U':>15} {'measured within U':>18} | rms before -> after (µm)")
    for name, t in tallies.items():
        print(f"{name:>9} | {t.written:>12} {t.left_out:>8} | {_shares(t)}")
    print(f"{'map':>35} | {'positions':>9} {'truth within U':>15} {'measured within U':>18} |")
    for name, t in tallies_by_family.items():
        print(f"{name:>35} | {_shares(t)}")
    for name, t in tallies.items():
        for reason in sorted(set(t.reasons))[:3]:
            print(f"  {name} left out: {reason}")


def _shares(t: Tally) -> str:
    if not t.positions:
        return f"{0:>9} {'-':>15} {'-':>18} | -"
    return (f"{t.positions:>9} {100 * t.within_truth / t.positions:>13.1f} % "
            f"{100 * t.within_measured / t.positions:>16.1f} % | "
            f"{np.sqrt(np.mean(t.before_sq)) * 1e3:.2f} -> "
            f"{np.sqrt(np.mean(t.after_sq)) * 1e3:.2f}")


if __name__ == "__main__":
    main()
