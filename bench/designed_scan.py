"""Benchmark (not a test): ``ogacq calibrate --simulator --effects E --yes`` with default
options on a 4 um cyclic screw error of pitch 5.0 mm on x, 6.35 mm on y and 4.0 mm on z
(each beside joint offsets), and the designed separating scan beside a uniform one.

Per case it prints the outcome and exit code, the separating scan's reading steps,
the axes a map was written for, and what the LinuxCNC tables leave against the
simulator's truth: over each axis's whole travel, every 0.1 mm, moving up and down,
where the joint lands for a commanded target, computed by hand from the physics (the
drive puts the screw at ``p = c + t + o`` for a target c, the table's trim t for the
direction of travel (LinuxCNC COMP_FILE_TYPE 1, linear between nominals, the end
values held beyond) and the offset o written to it; the joint is then at ``p + drho +
A sin(2 pi p / P + phase)``, ``ogacq/sim/truth.py``). ``rms`` is about the constant
(what the table leaves), ``const`` the constant (the offset register's step and the
offsets' identification), ``raw`` the error without the table.

Then the designed scan's machine time at 5.5 s a reading step beside the uniform scan
(every d mm, both directions, two cycles) with the largest d that samples every period
from 2 to 40 mm at 4 phases.

Run: python bench/designed_scan.py [--only 5.0] [--keep FOLDER] [--seed 1] [--noise-um 0.5]
[--stated] (``--stated``: a machine file stating x 5.0, y 6.35 and z 4.0 mm leads)

Seen with --stated (seed 1, 2026-12-07 s9): before the band was made continuous from the
shortest stated period the design raised IndexError (its band of one pitch); after it,
411 steps (band 2-40 mm), all three validated, the LinuxCNC tables leaving 0.24, 0.16
and 0.27 um rms of 2.83. With every axis stating 5 mm, a 4 um lead on x had ended "maps
not established" (28-40 mm searched, smooth maps on x, y and z); now 375 steps,
validated with a 4.997 mm map (A 8.26 -> 0.45 um).

Seen (seed 1, 2026-12, before the strata were placed for the smooth map): all three
validated (exit 0), 411 reading steps each, a map only on the axis with the error; the
LinuxCNC tables leave 0.40, 0.19 and 0.63 um rms of 2.83 (about a constant of 1-3 um:
the 0.01 mm offset register's step and the offsets' identification). Seed 2 on x:
pitch 4.977 mm, 0.80 um rms left. Designed 411 steps (38 min at 5.5 s) against a
uniform 0.66 mm scan of 2883 steps (4.4 h).

Seen (seed 1, 2026-12-07, the strata placed for the smooth map, each gauge's zero
taken out as the diagnosis does): at 5.5 s and 0.5 um, 411 steps reach 1.87 um on the
smooth map (equal strata 2.35 um; no placing of 34 targets goes below 1.76 um, of 37
targets, 447 steps, below 1.68 um: 1.5 um is beyond any placing along the axes in 450
steps, and takes 675), cyclic 0.80 um, hysteresis 0.74 um. Postures with the TCP moved
across the leg (none in the protocol) would bring it to 1.25 um (+-5 mm) or 0.91 um
(+-10 mm) in 450 steps. On the simulator: 5.0 mm on x and 6.35 mm on y in 411 steps,
4.0 mm on z in 1167 (its repeats showed less noise: 1.5 um within its 40 minutes at
about 2 s a step), all exit 0 ("not shown": the validation's gauges see the joint's
error over 16 mm only), a map only on the axis with the error, the LinuxCNC tables
leaving 0.29, 0.44 and 0.53 um rms of 2.83. The example machine's 10 um dial at the
2.4 um calibrate measured: cyclic 5.4, smooth 12.8, hysteresis 5.0 um in 411 steps
(each posture's cycles counted once: they round alike), 1.5 um needing some 31,000.

Seen (seeds 1, 2 and 3, 2026-12-07 (s6), after the simulator's ringing was left at
20 Hz where its lines run at its speed, and a pitch's std was taken from what the
model leaves with its term): every case validated, exit 0, the separating scan 411
reading steps (no reading again), the validation scan 399, a map only on the axis with
the error; the LinuxCNC tables leave 0.21 / 0.14 / 0.26 um rms (seed 1), 0.18 / 0.22 /
0.32 (seed 2), 0.16 / 0.35 / 0.32 (seed 3, beside two busy loops on the 2 cores) of
2.83 um, on x, y and z. The readings' noise measured from the repeats was 0.19-0.23 um
(before: 1.1 um, a 0.8 Hz creep left in every reading), at which calibrate's design
states 0.52 um cyclic, 1.22 um smooth, 0.47 um hysteresis. Those runs sampled the
ringing at points; with the gauges showing its mean between their values (as now):
seed 1 0.25 / 0.42 / 0.29 um and seed 3 0.20 / 0.14 / 0.30 um, all validated; seed 2
x and z validated, y once refused (a 3-value setting reading 5 sigma off the 12-value
readings' noise left the maps not established, and the calibration campaign's leg
length the offsets unidentifiable) and once "improved" (exit 0, 0.13 um: the
validation at 0.19 um sees the table's own error). The simulator runs in real time:
two runs of one seed differ.

Seen (seeds 1-20, 2026-12-07 (s8), every reading two windows, seeds 1-5 and 9-20 with
the pitch fitted in the final model): 60 runs, each exit 0, the separating scan 411
reading steps (once +399 resolving a pitch), maps only on the axis with the error, the
LinuxCNC tables leaving 0.12-0.52 um rms of 2.83; 59 validated, and seed 5 on z "not
shown": its 4 um map was sized at 41 points 4 mm apart, as 1 um, and the validation
held to showing that. Sized at the map's own points, seed 5 on z was validated in two
runs of two (0.41 and 0.28 um), seeds 17-20 in 12 of 12.
"""

from __future__ import annotations

import argparse
import dataclasses
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from ogacq.io.machine_file import write_machine
from ogacq.model.kinematics import nominal_q
from ogacq.model.machine import PAPER_PROTOTYPE, PAPER_PROTOTYPE_DIGITAL, Screw
from ogacq.model.measurement import ReadingsLayout
from ogacq.model.parameters import AXES, PARAM_INDEX
from ogacq.protocol.plan import ProtocolConfig, reading_steps, scan_targets
from ogacq.protocol.scan_design import (
    ALIAS_LIMIT,
    UNSTATED_BAND_MM,
    alias_level,
    allocation_of,
    design_scan,
    resolved_band,
    smooth_allocation,
)
from ogacq.session.records import CalibrateRecord
from ogacq.session.store import load_session
from ogacq.sim.truth import random_truth, read_effects
from ogacq.writeback.audit import operations
from ogacq.writeback.maps_table import read_maps_table

SEED = 1  # calibrate's default (--seed)
CASES = {"5.0 mm on x": ("x", 5.0), "6.35 mm on y": ("y", 6.35), "4.0 mm on z": ("z", 4.0)}
STEP_S = 5.5  # a reading step of a real station (the figure)
MOST_TARGETS_450 = 37  # the most targets of three legs' scan in 450 reading steps
DIAL_NOISE_MM = 0.0024  # calibrate's noise on the example machine's 10 um dial


def effects_text(axis: str, pitch_mm: float, noise_mm: float) -> str:
    return ("[joint_offset]\nx = 0.4\ny = -0.3\n"
            f"[gauges]\nnoise_mm = {noise_mm}\n"
            f"[lead_screw.{axis}]\namplitude_mm = 0.004\npitch_mm = {pitch_mm}\n")


def comp_trims(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rows = np.array([[float(v) for v in line.split()] for line in path.read_text().splitlines()
                     if line.strip()])
    return rows[:, 0], rows[:, 1], rows[:, 2]


def landed_error(folder: Path, axis: str, offsets_mm: dict[str, float],
                 seed: int = SEED) -> dict[str, float]:
    truth = read_effects(folder / "effects.toml", random_truth(seed))
    k = AXES.index(axis)
    drho = float(truth.theta[PARAM_INDEX[f"joint_offset.{axis}"]])
    screw = truth.lead_screw.get(k)
    m = PAPER_PROTOTYPE_DIGITAL
    targets = np.arange(m.rho_min_mm, m.rho_max_mm + 1e-9, 0.1)
    table = folder / "tables" / "linuxcnc" / f"{axis}.comp"
    out: dict[str, float] = {}
    for with_table in (True, False):
        errors = []
        for direction, order in ((1, targets), (-1, targets[::-1])):
            trim = np.zeros_like(order)
            if with_table and table.is_file():
                nominal, forward, reverse = comp_trims(table)
                trim = np.interp(order, nominal, forward if direction > 0 else reverse)
            p = order + trim + offsets_mm[axis]
            error = trim + offsets_mm[axis] + drho
            if screw is not None:
                error = error + screw.error_mm(p)
            if k in truth.screw_map:
                error = error + truth.screw_map[k].error_mm(p)
            errors.append(error)
        e = np.concatenate(errors) * 1e3
        key = "" if with_table else "raw_"
        out[key + "rms"] = float(np.std(e))
        out[key + "const"] = float(np.mean(e))
    return out


def reading_steps_of(path: Path) -> int:
    return len({r.step for r in load_session(path).readings}) if path.is_file() else 0


def stated_machine(root: Path) -> Path:
    """The digital prototype with each axis's lead stated, the cases' own (x 5.0, y 6.35,
    z 4.0 mm): the design then samples from the shortest stated period."""
    path = root / "machine-stated.toml"
    leads = {axis: Screw(pitch) for axis, pitch in CASES.values()}
    write_machine(path, dataclasses.replace(PAPER_PROTOTYPE_DIGITAL,
                                            screws=tuple(sorted(leads.items()))),
                  "the digital prototype, each axis's lead stated")
    return path


def run_case(root: Path, name: str, axis: str, pitch_mm: float, seed: int,
             noise_mm: float, machine: Path | None = None) -> None:
    folder = root / name.replace(" ", "-")
    effects = root / f"{axis}.toml"
    effects.write_text(effects_text(axis, pitch_mm, noise_mm))
    done = subprocess.run([sys.executable, "-m", "ogacq", "calibrate", "--simulator",
                           *(["--machine", str(machine)] if machine else []),
                           "--effects", str(effects), "--seed", str(seed), "--yes",
                           "--out", str(folder), "--history", "none"],
                          capture_output=True, text=True)
    steps = {r.step: r.details for r in
             load_session(folder / "procedure.jsonl").of_type(CalibrateRecord)}
    separating = steps.get("separation", {}).get("reading_steps")
    finished = steps.get("finished", {})
    maps = read_maps_table(folder / "maps.json").maps if (folder / "maps.json").is_file() \
        else {}
    written = [op for op in operations(load_session(folder / "calibration.jsonl"))
               if op.action == "write" and op.status == "done"]
    offsets = dict(written[-1].new_mm) if written else dict.fromkeys(AXES, 0.0)
    more = reading_steps_of(folder / "separating-more.jsonl")
    print(f"{name}: exit {done.returncode}, {finished.get('outcome')}; separating scan "
          f"{separating} reading steps" + (f" (+{more} resolving a pitch)" if more else "")
          + f", validation scan {reading_steps_of(folder / 'validation-scan.jsonl')}; maps "
          f"written on {sorted(maps) or 'no axis'}")
    print(f"  {finished.get('reason')}")
    for a in AXES:
        r = landed_error(folder, a, offsets, seed)
        print(f"  {a}: LinuxCNC table leaves {r['rms']:.2f} um rms about {r['const']:+.2f} um "
              f"(without it {r['raw_rms']:.2f} um rms)")


def uniform_step_resolving(band_mm: tuple[float, float]) -> float:
    """The largest uniform step (0.01 mm grid) whose targets sample the band at 4 phases,
    no alias keeping more than ALIAS_LIMIT (the design's own criteria)."""
    m = PAPER_PROTOTYPE_DIGITAL
    for step in np.arange(band_mm[0] / 2, 0.0, -0.01):
        plan = ProtocolConfig(scan_step_mm=round(float(step), 2), approach="both", cycles=2,
                              postures=())
        targets = np.array(scan_targets(plan, m))
        band, _ = resolved_band(targets, band_mm[1], band_mm[0])
        if band[0] <= band_mm[0] + 1e-9 and alias_level(targets, band_mm[0]) <= ALIAS_LIMIT:
            return round(float(step), 2)
    return 0.0


def compare_scans() -> None:
    m = PAPER_PROTOTYPE_DIGITAL
    base = ProtocolConfig(settle_s=1.0)
    design = design_scan(m, base, noise_mm=0.0005, seconds_per_step=STEP_S, budget_s=40 * 60)
    step = uniform_step_resolving(UNSTATED_BAND_MM)
    uniform = dataclasses.replace(base, scan_step_mm=step, approach="both", cycles=2,
                                  postures=())
    n = len(reading_steps(uniform, m))
    print(f"designed scan: {design.steps} reading steps, {design.steps * STEP_S / 60:.0f} min "
          f"at {STEP_S} s a step; band {design.pitch_band_mm[0]:g}-"
          f"{design.pitch_band_mm[1]:g} mm; detection (3 sigma at 0.5 um) "
          + ", ".join(f"{f} {v * 1e3:.2f} um" for f, v in design.detection_mm.items()))
    equal = design_scan(m, base, noise_mm=0.0005)  # no machine time: equal strata
    print(f"the same count in equal strata: {equal.steps} reading steps, smooth map "
          f"{equal.detection_mm['screw_map'] * 1e3:.2f} um")
    allocation = smooth_allocation(dataclasses.replace(
        design.protocol, scan_targets_mm=(design.targets_mm[0], design.targets_mm[-1])), m,
        0.0005)
    for targets in (len(design.targets_mm), MOST_TARGETS_450):
        print(f"smooth map, {targets} targets ({3 * (1 + 4 * targets)} reading steps): no "
              f"placing below {allocation.bound_mm(targets, 0.0005) * 1e3:.3f} um (the dual "
              "bound); the E-optimal allocation itself, as weights "
              f"{allocation.allocated_mm(targets, 0.0005) * 1e3:.3f}"
              " um")
    print(f"uniform scan resolving the same band: every {step:g} mm, {n} reading steps, "
          f"{n * STEP_S / 3600:.1f} h at {STEP_S} s a step")
    for offsets in ((0.0,), (0.0, 5.0, -5.0), (0.0, 10.0, -10.0)):
        bound, reached = off_axis_bound(offsets)
        print(f"postures with the TCP moved {', '.join(f'{t:+g}' for t in offsets)} mm across "
              f"the leg, 450 reading steps: smooth map no placing below {bound * 1e3:.2f} um, "
              f"the allocation {reached * 1e3:.2f} um")
    # the example machine's 10 um dial at the noise calibrate measured on it (2.4 um)
    dial = design_scan(PAPER_PROTOTYPE, base, noise_mm=DIAL_NOISE_MM, seconds_per_step=STEP_S,
                       budget_s=40 * 60)
    print(f"10 um dial at {DIAL_NOISE_MM * 1e3:g} um: {dial.steps} reading steps, detection "
          + ", ".join(f"{f} {v * 1e3:.2f} um" for f, v in dial.detection_mm.items())
          + f"; no placing below {dial.smooth_bound_mm * 1e3:.2f} um on the smooth map; "
          f"1.5 um would need {dial.target_steps} reading steps")


def off_axis_bound(offsets_mm: tuple[float, ...] = (0.0,),
                   visits: int = 149) -> tuple[float, float]:
    """The bound no allocation of ``visits`` reading steps per leg beats on the smooth map,
    and what the E-optimal allocation itself reaches (as weights)
    (0.5 um gauge, 1 um display), over candidate postures every 2 mm along each leg
    with the TCP moved ``offsets_mm`` across it, toward either other axis (the protocol
    has no such posture: what one would bring). A leg's gauges then read the leg line
    about half the offset away from where they were set: 10 mm keeps a 12.7 mm gauge
    set mid-range within it (``ReadingExpectations.gauge_range_mm``)."""
    m = PAPER_PROTOTYPE_DIGITAL
    lo, hi = m.rho_min_mm + 1.0, m.rho_max_mm - 1.0
    along = np.arange(lo, hi + 1e-9, 2.0)
    postures = [(s, k, t) for t in offsets_mm for k in ((1, 2) if t else (1,)) for s in along]
    q, leg, axis, at = [], [], [], []
    for i in range(3):
        tcps = [np.zeros(3)]
        for s, k, t in postures:
            p = np.zeros(3)
            p[i], p[(i + k) % 3] = s, t
            tcps.append(p)
        joints = nominal_q(np.array(tcps), m.leg_length_mm)
        for c, joint in enumerate(joints):
            for j in range(3):
                if j != i:
                    q.append(joint)
                    leg.append(i)
                    axis.append(j)
                    at.append(c - 1)  # the first, at Zero, sets the gauges
    layout = ReadingsLayout.build(q, leg, axis)
    allocation = allocation_of(layout, m, 0.0005, np.array(at), np.arange(len(postures)),
                               (0, 1, 2), (lo, hi))
    return allocation.bound_mm(visits, 0.0005), allocation.allocated_mm(visits, 0.0005)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", default="")
    parser.add_argument("--keep", type=Path, default=None)
    parser.add_argument("--seed", type=int, default=SEED)
    # the runs: "gauge noise 0.5 um" (the simulator's own default is 1 um)
    parser.add_argument("--noise-um", type=float, default=0.5)
    parser.add_argument("--stated", action="store_true",
                        help="the machine file states each axis's lead (--machine)")
    args = parser.parse_args()
    compare_scans()
    with tempfile.TemporaryDirectory() as tmp:
        root = args.keep or Path(tmp)
        root.mkdir(parents=True, exist_ok=True)
        machine = stated_machine(root) if args.stated else None
        for name, (axis, pitch) in CASES.items():
            if args.only in name:
                run_case(root, name, axis, pitch, args.seed, args.noise_um / 1000, machine)


if __name__ == "__main__":
    main()
