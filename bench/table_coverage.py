"""Benchmark: are the compensation tables' uncertainties honest? Over many simulated
seeds (prints figures; not a test).

Each seed: a machine with joint offsets and a lead screw's cyclic error on one axis
(random axis, amplitude 0.5-6 µm log-uniform, pitch 2-40 mm log-uniform over the band the designed
scan resolves, phase), sometimes a smooth screw error on another (a bend: its rms less
a straight line 1-6 µm, a straight error being an encoder scale); the separating scan
``calibrate`` designs for the papers' machine (``protocol.scan_design.design_scan``: 411
reading steps; ``--scan-step-mm 1``: every 1 mm up and down, pitch 4-12 mm, as this
bench ran before the design), its readings at 0.5 µm each (display 0.1 µm); the
diagnosis and its maps over the travel (zero at 0, as calibrate tabulates them); every
table format exported (``compensation.export``: only where
better than no table). Then a validation at positions other than those identified
from (uniform random over the travel, both directions): the table's correction as the
controller applies it (``AxisTable.applied``) against the simulator's truth, relative
to the reference (the constant is the joint offset's), and the same error as a
validation would measure it (plus one gauge reading's noise). Printed per format: the
share of validation positions whose error lies within the table's U (k = 2: the
map's at the position plus what the table's grid leaves of the map, as the table
states it, ``AxisTable.u_mm``), for the truth and for the measured error against U
combined with the reading's own (k = 2) (target >= 95 %); axes written / left out;
the rms error left against before, and the axes whose table left more than no table
at their validation positions. Then per family the detection limit the scan
achieved beside the one its design states (3 sigma, at the same noise): for the cyclic
error three times the scatter of its amplitude found about the truth, and the share
found at or above the size the design says the search finds reliably; for the smooth
map the share of bends found at or above the limit the design states and below it,
and three times the rms of the maps found less the truth, less a straight line;
and the scan's machine time beside a uniform scan that resolves the same leads (at
5.5 s a reading step).

Run: python bench/table_coverage.py [--seeds 100] [--scan-step-mm 1]

Seen (300 seeds, 2026-12-07 (s8), a pitch fitted in the final model,
``diagnose/mappolish.py``), truth / measured within U: LinuxCNC 96.5 / 95.4 %,
SINUMERIK 97.3 / 96.2 %, FANUC 99.0 / 98.8 %, CSV 95.3 / 95.1 %; cyclic maps 97.8 %,
smooth maps 95.4 %; no axis made worse in any format. Before it (the pitch of the
search's step, its std from that step's curvature): 95.5 / 95.0, 96.6 / 95.8,
99.0 / 98.8, 94.0 / 94.5 %; cyclic 96.5 %; one LinuxCNC axis made worse.
"""

from __future__ import annotations

import argparse
import math
import tempfile
import time
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from designed_scan import uniform_step_resolving  # bench/, beside this file

from ogacq.compensation.export import export_tables
from ogacq.compensation.formats import TABLE_FORMATS
from ogacq.diagnose.diagnosis import diagnose
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import AXES, vector
from ogacq.protocol.plan import ProtocolConfig, planned_layout, reading_steps
from ogacq.protocol.scan_design import ScanDesign, design_scan, sampled_band
from ogacq.sim.readings import simulated_readings
from ogacq.sim.truth import LeadScrewError, ScrewMap, SimTruth

MACHINE = MachineSpec(310.25, -100.0, 60.0, gauge_resolution_mm=0.0001)
NOISE_MM = 0.0005
VALIDATION_POSITIONS = 20  # per axis and direction
AMPLITUDE_MM = (0.0005, 0.006)  # log-uniform: about the detection limit and well above
PITCH_MM = (4.0, 12.0)  # on the 1 mm scan; the design's band on the designed scan
STEP_S = 5.5  # a reading step on a real station (the figure)
SMOOTH_SHARE = 0.3  # seeds with a smooth screw error on another axis too
BEND_UM = (1.0, 6.0)  # its size: rms over the travel less a straight line
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
    worse: int = 0  # axes whose table leaves more than no table at the validation
    worse_cases: list[str] = field(default_factory=list)


tallies_by_family: dict[str, Tally] = defaultdict(Tally)  # every format's validations


@dataclass
class Found:
    """Per family: what the scan found against the truth, over the seeds (each planted
    error's size, whether found, and the error of what was found)."""

    sizes_mm: list[float] = field(default_factory=list)
    found: list[bool] = field(default_factory=list)
    errors_mm: list[float] = field(default_factory=list)


found_by_family: dict[str, Found] = defaultdict(Found)


def truth_of(rng: np.random.Generator, pitch_mm: tuple[float, float]) -> SimTruth:
    offsets = {f"joint_offset.{a}": float(rng.uniform(-0.5, 0.5)) for a in AXES}
    cyclic = int(rng.integers(3))
    pitch = math.exp(rng.uniform(math.log(pitch_mm[0]), math.log(pitch_mm[1])))
    amplitude = math.exp(rng.uniform(math.log(AMPLITUDE_MM[0]), math.log(AMPLITUDE_MM[1])))
    lead = {cyclic: LeadScrewError(amplitude, pitch,
                                   float(rng.uniform(0, 360)))}
    smooth = {}
    if rng.random() < SMOOTH_SHARE:
        other = (cyclic + 1 + int(rng.integers(2))) % 3
        smooth = {other: bend(rng)}
    return SimTruth(vector(offsets), NOISE_MM, lead, screw_map=smooth)


def bend_rms_mm(smooth: ScrewMap) -> float:
    q = np.linspace(MACHINE.rho_min_mm, MACHINE.rho_max_mm, 161)
    e = smooth.error_mm(q)
    return float(np.sqrt(np.mean((e - np.polyval(np.polyfit(q, e, 1), q)) ** 2)))


def bend(rng: np.random.Generator) -> ScrewMap:
    """A smooth screw error of square and cube terms (no straight one: that is an
    encoder scale, the library's), scaled to a bend of ``BEND_UM``."""
    shape = ScrewMap((0.0, float(rng.uniform(-1, 1)), float(rng.uniform(-1, 1))))
    size = float(rng.uniform(*BEND_UM)) / 1e3 / bend_rms_mm(shape)
    return ScrewMap(tuple(c * size for c in shape.coefficients_mm))


def true_error_mm(truth: SimTruth, axis: int, q: np.ndarray) -> np.ndarray:
    """Actual minus commanded along the joint, less its value at the reference (0)."""
    grid = np.zeros((len(q) + 1, 3))
    grid[:-1, axis] = q
    moved = truth.disturbed_q(grid)[:, axis] - grid[:, axis]
    return moved[:-1] - moved[-1]


@dataclass(frozen=True)
class Scan:
    protocol: ProtocolConfig
    pitch_mm: tuple[float, float]  # the truth's leads
    band_mm: tuple[float, float] | None  # the design's, given to the diagnosis
    design: ScanDesign | None


def scan_of(step_mm: float | None) -> Scan:
    if step_mm:
        return Scan(ProtocolConfig(scan_step_mm=step_mm, cycles=CYCLES, approach="both",
                                   postures=()), PITCH_MM, None, None)
    design = design_scan(MACHINE, ProtocolConfig(), noise_mm=NOISE_MM)
    band = sampled_band(design.protocol, MACHINE)
    return Scan(design.protocol, band, band, design)


def one_seed(seed: int, scan: Scan, tallies: dict[str, Tally], folder: Path) -> bool:
    rng = np.random.default_rng(seed)
    truth = truth_of(rng, scan.pitch_mm)
    layout = planned_layout(scan.protocol, MACHINE)
    obs = simulated_readings(MACHINE, layout, truth, scatter_mm=NOISE_MM,
                             step_mm=MACHINE.gauge_resolution_mm, seed=seed)
    d = diagnose(obs, pitch_band_mm=scan.band_mm)
    _tally_found(d, truth)
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


def _tally_found(d, truth: SimTruth) -> None:
    """Each planted error against what the diagnosis found of it: the cyclic error's
    amplitude, the smooth map over the travel (less its value at 0, as tabulated)."""
    steps = {s.added.term.name: s.added for s in d.mapped.search.steps} \
        if d.mapped is not None else {}
    for axis, lead in truth.lead_screw.items():
        tally = found_by_family["lead_screw_cyclic"]
        got = steps.get(f"lead_screw_cyclic.{AXES[axis]}")
        tally.sizes_mm.append(lead.amplitude_mm)
        tally.found.append(got is not None)
        if got is not None:
            tally.errors_mm.append(float(np.hypot(*got.coefficients[:2])) - lead.amplitude_mm)
    span = (MACHINE.rho_min_mm, MACHINE.rho_max_mm)
    maps = {m.axis: m for m in d.maps_over(dict.fromkeys(AXES, span), dict.fromkeys(AXES, 0.0))}
    for axis, smooth in truth.screw_map.items():
        tally = found_by_family["screw_map"]
        m = maps.get(AXES[axis])
        found = m is not None and "screw_map" in m.extra.get("families", [])
        tally.sizes_mm.append(bend_rms_mm(smooth))
        tally.found.append(found)
        if found:
            q = np.linspace(*span, 161)
            # less a straight line: the library's encoder scale takes that part, apart
            left = np.interp(q, m.positions_mm, m.forward_mm) - smooth.error_mm(q)
            left -= np.polyval(np.polyfit(q, left, 1), q)
            tally.errors_mm.append(float(np.sqrt(np.mean(left ** 2))))


def _validate(name, written, options, truth, rng, tally: Tally) -> None:
    fmt = TABLE_FORMATS[name]
    (tables,) = fmt.tables(written, "validation", options)
    for axis, table in tables.axes.items():
        m = table.axis_map
        i = AXES.index(axis)
        family = tallies_by_family[m.source.split(",")[0].split(" (")[0]]
        q = rng.uniform(m.positions_mm[0], m.positions_mm[-1], VALIDATION_POSITIONS)
        before = after = 0.0
        for side in (1, -1):
            error = true_error_mm(truth, i, q)
            residual = error - table.applied(q, side)
            before, after = before + float(error @ error), after + float(residual @ residual)
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
        for t in (tally, family):
            t.worse += after > before
        if after > before:
            tally.worse_cases.append(
                f"{axis} ({m.source}): rms {math.sqrt(before / (2 * len(q))) * 1e3:.2f} -> "
                f"{math.sqrt(after / (2 * len(q))) * 1e3:.2f} um, the map's largest "
                f"{max(map(abs, m.forward_mm)) * 1e3:.2f} um, U up to "
                f"{K * max(m.u_forward_mm) * 1e3:.2f} um")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=100)
    parser.add_argument("--scan-step-mm", type=float, default=None,
                        help="a uniform scan at this step instead of the designed one")
    args = parser.parse_args()
    scan = scan_of(args.scan_step_mm)
    tallies: dict[str, Tally] = defaultdict(Tally)
    start = time.perf_counter()
    mapped = 0
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(args.seeds):
            mapped += one_seed(seed, scan, tallies, Path(tmp))
    print(f"{args.seeds} seeds ({mapped} with maps) in {time.perf_counter() - start:.0f} s; "
          f"validation at {VALIDATION_POSITIONS} random positions per axis and direction, "
          f"gauge noise {NOISE_MM * 1e3:g} µm; U: k = {K:g}, the table's (its map's U at the "
          "position plus what its grid leaves of the map)")
    print(f"{'format':>9} | {'axes written':>12} {'left out':>8} | {'positions':>9} "
          f"{'truth within U':>15} {'measured within U':>18} | rms before -> after (µm) | "
          "axes made worse")
    for name, t in tallies.items():
        print(f"{name:>9} | {t.written:>12} {t.left_out:>8} | {_shares(t)} | {t.worse}")
    print(f"{'map':>35} | {'positions':>9} {'truth within U':>15} {'measured within U':>18} |"
          " rms before -> after (µm) | axes made worse (every format)")
    for name, t in tallies_by_family.items():
        print(f"{name:>35} | {_shares(t)} | {t.worse}")
    for name, t in tallies.items():
        for reason in sorted(set(t.reasons))[:3]:
            print(f"  {name} left out: {reason}")
        for case in t.worse_cases:
            print(f"  {name} made worse: {case}")
    _print_detection(scan)
    _print_machine_time(scan)


def _print_detection(scan: Scan) -> None:
    stated = scan.design.detection_mm if scan.design is not None else {}
    for family, f in found_by_family.items():
        errors, sizes, found = np.array(f.errors_mm), np.array(f.sizes_mm), np.array(f.found)
        line = (f"{family}: found in {found.sum()} of {len(found)} seeds (sizes "
                f"{sizes.min() * 1e3:.1f}-{sizes.max() * 1e3:.1f} µm)")
        for what, limits in (("3-sigma limit", stated), ("found-reliably size",
                                                          scan.design.found_mm
                                                          if scan.design else {})):
            limit = limits.get(family)
            if limit is not None:
                at = sizes >= limit
                line += (f"; at or above the design's {what} {limit * 1e3:.2f} µm: "
                         f"{found[at].sum()} of {at.sum()}, below it {found[~at].sum()} of "
                         f"{(~at).sum()}")
        if len(errors) > 1:
            if family == "lead_screw_cyclic":
                line += (f"; detection achieved {3 * float(np.std(errors)) * 1e3:.2f} µm "
                         "(3 x the amplitude's scatter about the truth)")
            else:
                line += (f"; 3 x the rms of the maps found less the truth (less a straight "
                         f"line) {3 * float(np.sqrt(np.mean(errors ** 2))) * 1e3:.2f} µm")
        print(line)


def _print_machine_time(scan: Scan) -> None:
    steps = len(reading_steps(scan.protocol, MACHINE))
    print(f"the scan: {steps} reading steps, {steps * STEP_S / 60:.0f} min at {STEP_S} s a "
          "step")
    if scan.design is None:
        return
    band = scan.pitch_mm
    step = uniform_step_resolving(band)  # designed_scan's: 4 phases, no strong alias
    uniform = ProtocolConfig(scan_step_mm=step, approach="both", cycles=scan.protocol.cycles,
                             postures=())
    n = len(reading_steps(uniform, MACHINE))
    print(f"a uniform scan resolving the same leads ({band[0]:g}-{band[1]:g} mm): every "
          f"{step:.2f} mm, {n} reading steps, {n * STEP_S / 3600:.1f} h")


def _shares(t: Tally) -> str:
    if not t.positions:
        return f"{0:>9} {'-':>15} {'-':>18} | -"
    return (f"{t.positions:>9} {100 * t.within_truth / t.positions:>13.1f} % "
            f"{100 * t.within_measured / t.positions:>16.1f} % | "
            f"{np.sqrt(np.mean(t.before_sq)) * 1e3:.2f} -> "
            f"{np.sqrt(np.mean(t.after_sq)) * 1e3:.2f}")


if __name__ == "__main__":
    main()
