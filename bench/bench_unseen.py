"""Sweep (not a test): the identification and the diagnosis on machines, protocols and
physics unlike the bench and papers ones.

Per case, over SEEDS campaigns drawn by ``ogacq.sim.readings.simulated_readings`` (the
exact model at a stated truth, arbitrary gauge zeros, Gaussian gauge scatter, rounding
to the display step), prints:

* ``conv``: share of joint-offset fits that converged with finite std;
* ``cov``: coverage of the joint offsets fitted alone by their stated 95 % interval
  (|value - truth| <= 1.96 std), over the three axes; expected 0.95 where the truth has
  nothing but offsets (the cases marked ``-``), lower where the offsets-only model is
  wrong (they are not judged there);
* ``cov_t``: the same with Student's t quantile for the noise's degrees of freedom
  where the noise is measured from the repeats (few repeats: few dof, 1.96 too short);
* ``any``: share of campaigns where the diagnosis names any effect (library or map);
  on pure noise this is its false-claim rate (the verdict's level is 0.01);
* ``hit``: share naming every effect the truth holds (the expected names);
* ``wrong``: share naming an effect outside the expected set;
* ``sure``: share naming, with confidence (no alternative, fit within the noise:
  ``Diagnosis.confident``), an effect outside the expected set;
* ``ecov``: coverage of the expected library effects' values by value +- 1.96 std, in the
  campaigns where they were named;
* ``incon``: share whose final fit is still beyond the noise (an unexplained misfit);
* ``outl``: share where a reading is named far from its agreeing repeats (none is
  planted: on these campaigns every one named is a false claim);
* ``sig``: what the effects leave after the offsets-only fit, noise-free, rms in units
  of the gauge noise: an effect with a large ``sig`` that is not named is missed;
* ``bad``: crashes, NaN or non-finite std among the claims, non-convergence.

Run: python bench/bench_unseen.py [SEEDS, default 6] [--only SUBSTRING]
"""

from __future__ import annotations

import argparse
import sys
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.stats import t as student_t

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from ogacq.diagnose.diagnosis import EffectFound, diagnose  # noqa: E402
from ogacq.identify.fit import fit  # noqa: E402
from ogacq.identify.observations import readings_observations  # noqa: E402
from ogacq.model.machine import MachineSpec  # noqa: E402
from ogacq.model.measurement import ReadingsLayout  # noqa: E402
from ogacq.model.parameters import PARAM_SETS, vector  # noqa: E402
from ogacq.protocol.plan import ProtocolConfig, planned_layout  # noqa: E402
from ogacq.sim.physics import true_coordinates  # noqa: E402
from ogacq.sim.readings import simulated_readings  # noqa: E402
from ogacq.sim.truth import (  # noqa: E402
    Hysteresis,
    LeadScrewError,
    RailBow,
    ScrewMap,
    SimTruth,
    WarmUp,
)

NOISE = 0.002
STEP = 0.001
OFFSETS = {"joint_offset.x": 2.0, "joint_offset.y": 2.0, "joint_offset.z": -2.0}
FEW_MM = {"joint_offset.x": 4.5, "joint_offset.y": -3.0, "joint_offset.z": 5.5}
INCH_STEP = 0.0001 * 25.4  # a 0.0001 in display, read in mm


def machine(leg: float, lo: float, hi: float, step: float = STEP,
            noise: float | None = NOISE) -> MachineSpec:
    return MachineSpec(leg, lo, hi, gauge_resolution_mm=step, gauge_repeatability_mm=noise)


PAPER = machine(310.25, -100.0, 60.0)
SMALL = machine(120.0, -30.0, 20.0)
LARGE = machine(900.0, -300.0, 250.0)
NARROW = machine(310.25, -15.0, 10.0)
ASYM = machine(310.25, -160.0, 20.0)
DIAL = machine(310.25, -100.0, 60.0, step=0.01, noise=0.004)
INCH = machine(310.25, -100.0, 60.0, step=INCH_STEP, noise=NOISE)
UNSTATED = machine(310.25, -100.0, 60.0, noise=None)
UNSTATED_SMALL = machine(120.0, -30.0, 20.0, noise=None)
DIAL_UNSTATED = machine(310.25, -100.0, 60.0, step=0.01, noise=None)
INCH_UNSTATED = machine(310.25, -100.0, 60.0, step=INCH_STEP, noise=None)


@dataclass(frozen=True)
class Case:
    name: str
    spec: MachineSpec
    protocol: dict
    effects: dict[str, float] = field(default_factory=dict)
    physics: dict = field(default_factory=dict)  # SimTruth's axis errors
    expected: frozenset[str] = frozenset()  # names the diagnosis should give
    # names that are no false claim beside the expected ones: the same physics seen
    # through a near-alias (a lost motion that builds up also shows as backlash)
    tolerated: frozenset[str] = frozenset()
    offsets: dict[str, float] = field(default_factory=lambda: dict(OFFSETS))
    scatter: float = NOISE

    @property
    def offsets_only(self) -> bool:
        return not self.effects and not self.physics

    def truth(self) -> SimTruth:
        return SimTruth(vector({**self.offsets, **self.effects}), **self.physics)

    def layout(self) -> ReadingsLayout:
        return planned_layout(ProtocolConfig(**self.protocol), self.spec)


RICH = ("zero", 15.0, "max", 15.0, "zero", -20.0, "min", -20.0, "zero")
RICH_PAPER = ("zero", 30.0, "max", 30.0, "zero", -50.0, "min", -50.0, "zero")


def cases() -> list[Case]:
    out = [
        # pure noise on unusual geometry and protocols
        Case("paper/3cyc noise", PAPER, {}),
        Case("small noise", SMALL, {}),
        Case("large noise", LARGE, {}),
        Case("narrow noise", NARROW, {}),
        Case("asym noise", ASYM, {}),
        Case("offsets few mm noise", PAPER, {}, offsets=FEW_MM),
        Case("1 cycle noise", PAPER, {"cycles": 1}),
        Case("6 cycles noise", PAPER, {"cycles": 6}),
        Case("rich postures noise", PAPER, {"postures": RICH_PAPER}),
        Case("legs x,y only noise", PAPER, {"legs": ("x", "y")}),
        Case("scan 10mm noise", PAPER, {"scan_step_mm": 10.0, "cycles": 2}),
        Case("inch display noise", INCH, {}),
        Case("0.01 dial noise", DIAL, {}, scatter=0.004),
        Case("noise unstated", UNSTATED, {}),
        Case("small 1 cycle noise", SMALL, {"cycles": 1}),
        Case("1 cycle noise unstated", UNSTATED, {"cycles": 1}),
        Case("scan 1 cycle noise unstated", UNSTATED, {"scan_step_mm": 5.0, "cycles": 1}),
        Case("legs x,y 1 cycle noise unstated", UNSTATED, {"legs": ("x", "y"), "cycles": 1}),
        Case("leg z 2 cycles noise unstated", UNSTATED, {"legs": ("z",), "cycles": 2}),
        Case("small 1 cycle 0.5um noise unstated", UNSTATED_SMALL, {"cycles": 1},
             scatter=0.0005),
        Case("dial 1um scatter unstated", DIAL_UNSTATED, {}, scatter=0.001),
        Case("inch 6 cycles unstated", INCH_UNSTATED, {"cycles": 6}),
        Case("large scan noise", LARGE, {"scan_step_mm": 25.0, "cycles": 2}),
        # library effects, alone, pairs, small and large
        Case("leg_length.y 0.3", PAPER, {}, {"leg_length.y": 0.3},
             expected=frozenset({"leg_length.y"})),
        Case("small leg_length.y 0.3", SMALL, {}, {"leg_length.y": 0.3},
             expected=frozenset({"leg_length.y"})),
        Case("large leg_length.y 0.3", LARGE, {}, {"leg_length.y": 0.3},
             expected=frozenset({"leg_length.y"})),
        Case("leg_length.y 0.03 (small)", PAPER, {}, {"leg_length.y": 0.03},
             expected=frozenset({"leg_length.y"})),
        Case("squareness.xy 0.5", PAPER, {}, {"squareness.xy": 0.5},
             expected=frozenset({"squareness.xy"})),
        Case("large squareness.xy 0.2", LARGE, {}, {"squareness.xy": 0.2},
             expected=frozenset({"squareness.xy"})),
        Case("backlash.x 0.02 rich", PAPER, {"postures": RICH_PAPER}, {"backlash.x": 0.02},
             expected=frozenset({"backlash.x"})),
        Case("small backlash.x 0.02 rich", SMALL, {"postures": RICH},
             {"backlash.x": 0.02}, expected=frozenset({"backlash.x"})),
        Case("encoder_scale.z 500", PAPER, {}, {"encoder_scale.z": 500.0},
             expected=frozenset({"encoder_scale.z"})),
        Case("thermal_drift.x 0.05", PAPER, {"cycles": 6}, {"thermal_drift.x": 0.05},
             expected=frozenset({"thermal_drift.x"}), tolerated=frozenset({"warm_up.x"})),
        Case("pair leg_length.y+squareness.xz", PAPER, {"postures": RICH_PAPER},
             {"leg_length.y": 0.2, "squareness.xz": 0.5},
             expected=frozenset({"leg_length.y", "squareness.xz"})),
        Case("inch leg_length.z -0.2", INCH, {}, {"leg_length.z": -0.2},
             expected=frozenset({"leg_length.z"})),
        Case("dial leg_length.z -0.3", DIAL, {}, {"leg_length.z": -0.3},
             expected=frozenset({"leg_length.z"}), scatter=0.004),
        # outside the library
        Case("scan lead screw x 5um/5mm", PAPER, {"scan_step_mm": 1.0, "cycles": 1}, {},
             {"lead_screw": {0: LeadScrewError(0.005, 5.0, 30.0)}},
             expected=frozenset({"lead_screw_cyclic.x"})),
        Case("large scan lead screw y 20um/20mm", LARGE, {"scan_step_mm": 4.0, "cycles": 1},
             {}, {"lead_screw": {1: LeadScrewError(0.02, 20.0, 0.0)}},
             expected=frozenset({"lead_screw_cyclic.y"})),
        Case("small scan screw map z", SMALL, {"scan_step_mm": 1.0, "cycles": 2}, {},
             {"screw_map": {2: ScrewMap((0.0, 1.0))}}, expected=frozenset({"screw_map.z"})),
        Case("scan rail bow z->x 10um", PAPER, {"scan_step_mm": 4.0, "cycles": 2}, {},
             {"rail_bow": {2: RailBow("x", 0.01)}}, expected=frozenset({"rail_bow.zx"})),
        Case("scan hysteresis z", PAPER, {"scan_step_mm": 2.0, "cycles": 1}, {},
             {"hysteresis": {2: Hysteresis(0.02, 6.0)}},
             expected=frozenset({"hysteresis.z"}), tolerated=frozenset({"backlash.z"})),
        Case("warm-up y 50um 6cyc", PAPER, {"cycles": 6}, {},
             {"warm_up": {1: WarmUp(0.05, 1800.0)}}, expected=frozenset({"warm_up.y"}),
             tolerated=frozenset({"thermal_drift.y"})),
        Case("warm-up y 10um 6cyc", PAPER, {"cycles": 6}, {},
             {"warm_up": {1: WarmUp(0.01, 1800.0)}}, expected=frozenset({"warm_up.y"}),
             tolerated=frozenset({"thermal_drift.y"})),
        Case("sparse lead screw x 20um", PAPER, {}, {},
             {"lead_screw": {0: LeadScrewError(0.02, 5.0, 30.0)}}),
    ]
    return out


@dataclass
class Tally:
    n: int = 0
    converged: int = 0
    covered: int = 0
    covered_t: int = 0
    judged: int = 0
    any_named: int = 0
    hit: int = 0
    wrong: int = 0
    ecov: int = 0
    inconsistent: int = 0
    outliers: int = 0
    sure_wrong: int = 0
    sure_names: dict[str, int] = field(default_factory=dict)
    ejudged: int = 0
    bad: list[str] = field(default_factory=list)
    names: dict[str, int] = field(default_factory=dict)
    seconds: float = 0.0
    signature: float = 0.0


def signature(case: Case, lay: ReadingsLayout, truth: SimTruth) -> float:
    """What the offsets-only fit leaves of the noise-free readings, in noise units."""
    clean = readings_observations(case.spec, lay, true_coordinates(truth, lay, case.spec))
    return fit(clean, PARAM_SETS["offsets"]).residual_rms_mm / case.scatter


def run_case(case: Case, seeds: int, diag: Callable = diagnose) -> Tally:
    t = Tally()
    lay = case.layout()
    truth = case.truth()
    t.signature = signature(case, lay, truth)
    start = time.perf_counter()
    for seed in range(seeds):
        t.n += 1
        try:
            obs = simulated_readings(case.spec, lay, truth, scatter_mm=case.scatter,
                                     step_mm=case.spec.gauge_resolution_mm, seed=seed)
            f = fit(obs, PARAM_SETS["offsets"])
            ok = f.converged and bool(np.all(np.isfinite(f.std))) and bool(
                np.all(f.std > 0))
            t.converged += ok
            if not ok:
                t.bad.append(f"seed {seed}: offsets fit {f.stop_reason} std {f.std}")
            if case.offsets_only and ok:
                # a noise measured from few repeats: Student's t with its dof
                k = student_t.ppf(0.975, f.noise.dof) if f.noise.measured and f.noise.dof \
                    else 1.96
                for name, value, std in zip(f.names, f.values, f.std, strict=True):
                    t.judged += 1
                    t.covered += abs(value - case.offsets[name]) <= 1.96 * std
                    t.covered_t += abs(value - case.offsets[name]) <= k * std
            d = diag(obs)
            named = {e.name for e in d.effects}
            for n in named:
                t.names[n] = t.names.get(n, 0) + 1
            t.any_named += bool(named)
            t.hit += bool(case.expected) and case.expected <= named
            t.wrong += bool(named - case.expected - case.tolerated)
            t.inconsistent += d.final.judged and not d.final.consistent
            t.outliers += d.outliers is not None
            confidently_wrong = set(d.confident()) - case.expected - case.tolerated
            t.sure_wrong += bool(confidently_wrong)
            for n in confidently_wrong:
                t.sure_names[n] = t.sure_names.get(n, 0) + 1
            for e in d.effects:
                value = e.value if isinstance(e, EffectFound) else e.value.value
                if not (np.isfinite(e.std) and np.isfinite(value)):
                    t.bad.append(f"seed {seed}: {e.name} value/std not finite")
                if isinstance(e, EffectFound) and e.name in case.effects:
                    t.ejudged += 1
                    t.ecov += abs(e.value - case.effects[e.name]) <= 1.96 * e.std
        except Exception as exc:  # a crash is a finding
            t.bad.append(f"seed {seed}: {type(exc).__name__}: {exc}")
            traceback.print_exc()
    t.seconds = time.perf_counter() - start
    return t


def rate(k: int, n: int) -> str:
    return "  -  " if n == 0 else f"{k / n:5.2f}"


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("seeds", nargs="?", type=int, default=6)
    parser.add_argument("--only", default="")
    args = parser.parse_args()
    print(f"{args.seeds} seeds per case; gauge noise {NOISE * 1e3:g} um unless said")
    columns = ("conv", "cov", "cov_t", "any", "hit", "wrong", "sure", "ecov", "incon", "outl")
    print(f"{'case':38s} " + " ".join(f"{c:>5s}" for c in columns) + "    sig    s  named")
    for case in cases():
        if args.only and args.only not in case.name:
            continue
        t = run_case(case, args.seeds)
        rates = (rate(t.converged, t.n), rate(t.covered, t.judged),
                 rate(t.covered_t, t.judged), rate(t.any_named, t.n),
                 rate(t.hit, t.n) if case.expected else "  -  ", rate(t.wrong, t.n),
                 rate(t.sure_wrong, t.n), rate(t.ecov, t.ejudged), rate(t.inconsistent, t.n),
                 rate(t.outliers, t.n))
        named = ", ".join(f"{k}:{v}" for k, v in sorted(t.names.items(), key=lambda kv: -kv[1]))
        print(f"{case.name:38s} " + " ".join(rates) +
              f" {t.signature:6.1f} {t.seconds:4.0f}  {named}", flush=True)
        if t.sure_names:
            print(f"    claimed with confidence, wrongly: {t.sure_names}")
        for line in t.bad[:3]:
            print(f"    BAD {line}", flush=True)


if __name__ == "__main__":
    main()
