"""The write-back policy as pure data: the sign, the register step, every reason to
refuse, and the restore plan; the fit verdict on seeded synthetic campaigns."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from ogacq_drivers.axes.profile import load_profile
from ogacq.identify.consistency import LEVEL, Verdict, fit_verdict
from ogacq.identify.fit import StopReason, fit
from ogacq.identify.noise import GaugeNoise
from ogacq.identify.observations import readings_observations
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import AXES, PARAM_SETS, vector
from ogacq.protocol.plan import ProtocolConfig, planned_layout
from ogacq.writeback.audit import Operation
from ogacq.writeback.evidence import Evidence
from ogacq.writeback.policy import ControllerFacts, WritePolicy, plan_restore, plan_write

CIA = ControllerFacts.of(load_profile("cia402"))
IAI = ControllerFacts.of(load_profile("iai-pcon"))
ZEROS = dict.fromkeys(AXES, 0.0)
NOISE = GaugeNoise(0.001, "machine file", 0.0001, 0.001)
GOOD = Verdict("consistent", "chi-square", 60.0, 63, None, 0.6, 0.6, LEVEL, 6e-5, 0.001, NOISE)
BAD = Verdict("inconsistent", "chi-square", 4000.0, 63, None, 0.0, 0.0, LEVEL, 4e-3, 0.008,
              NOISE)


def evidence(identified, *, std=0.001, verdict=GOOD, identifiable=True, in_force=ZEROS,
             finished=True, converged=True, in_force_consistent=True,
             profile="cia402", outliers=()) -> Evidence:
    return Evidence(
        session_path=Path("s.jsonl"), identified_mm=dict(zip(AXES, identified, strict=True)),
        std_mm=dict.fromkeys(AXES, std), verdict=verdict, identifiable=identifiable,
        identifiability_reasons=[] if identifiable else ["rank 2 of 3"],
        fit_stop=StopReason.COST_STALLED if converged else StopReason.MAX_ITERATIONS,
        residual_rms_mm=0.001, readings=72, finished=finished,
        in_force_mm=None if in_force is None else dict(in_force),
        in_force_consistent=in_force_consistent, profile=profile, port="p",
        outliers=list(outliers))


def codes(plan) -> list[str]:
    return [r.code for r in plan.refusals]


def test_new_offset_is_the_one_in_force_minus_the_identified_rounded_to_the_register():
    base = {"x": 0.30, "y": -0.20, "z": 0.00}
    plan = plan_write(evidence((0.4567, -1.2341, 0.0049), in_force=base), base, CIA)
    assert plan.new_mm == pytest.approx({"x": -0.16, "y": 1.03, "z": -0.0})
    assert plan.current_mm == base and not plan.refused and not plan.nothing_to_do
    assert any("register step 0.01 mm" in n for n in plan.notes)
    # the software table keeps the value (to 1e-6 mm)
    plan = plan_write(evidence((0.4567, -1.2341, 0.0049), in_force=base, profile="iai-pcon"),
                      base, IAI)
    assert plan.new_mm == pytest.approx({"x": -0.1567, "y": 1.0341, "z": -0.0049})
    assert plan.facts.takes_effect == "now"


@pytest.mark.parametrize(("kwargs", "code"), [
    ({"verdict": BAD}, "inconsistent"),
    ({"identifiable": False, "std": math.inf}, "unidentifiable"),
    ({"converged": False}, "not_converged"),
    ({"finished": False}, "incomplete"),
    ({"in_force": None}, "unknown_baseline"),
    ({"in_force_consistent": False}, "mixed_baseline"),
    ({"profile": "iai-pcon"}, "other_profile"),
    ({"outliers": ["z_x at zero, cycle 2 (t_s 80): +0.0300 mm from its 4 repeats"]},
     "outlier"),
])
def test_each_unreliable_result_is_refused_with_its_reason(kwargs, code):
    plan = plan_write(evidence((0.5, -0.5, 0.2), **kwargs), ZEROS, CIA)
    assert codes(plan) == [code]
    assert plan.refusals[0].message  # says why, in words


def test_a_fit_that_did_not_converge_is_refused_saying_why_it_stopped():
    plan = plan_write(evidence((0.5, -0.5, 0.2), converged=False), ZEROS, CIA)
    assert plan.refusals[0].message == ("the offsets fit did not converge: stopped after 30 "
                                        "iterations, still moving")


def test_the_verdict_and_identifiability_reasons_are_in_the_message():
    plan = plan_write(evidence((0.5, -0.5, 0.2), verdict=BAD), ZEROS, CIA)
    assert "chi2(63) = 4000" in plan.refusals[0].message
    assert "ogacq diagnose" in plan.refusals[0].message
    plan = plan_write(evidence((0.5, -0.5, 0.2), identifiable=False, std=math.inf), ZEROS, CIA)
    assert "rank 2 of 3" in plan.refusals[0].message
    assert not any("two std" in n for n in plan.notes)  # an infinite std is not "noise"


def test_change_limit_and_controller_margin():
    plan = plan_write(evidence((-2.5, 0.1, 0.1)), ZEROS, CIA)
    assert codes(plan) == ["too_large", "beyond_margin"]
    assert "x +2.5000" in plan.refusals[0].message and "2 mm limit" in plan.refusals[0].message
    plan = plan_write(evidence((-1.5, 0.1, 0.1)), ZEROS, CIA, WritePolicy(max_change_mm=1.0))
    assert codes(plan) == ["too_large"]
    # the limit is on the change: a large offset reached by a small step passes
    base = {"x": 1.7, "y": 0.0, "z": 0.0}
    plan = plan_write(evidence((-0.2, 0.0, 0.0), in_force=base), base, CIA)
    assert codes(plan) == []


def test_writing_twice_is_nothing_to_do_and_a_later_change_is_stale():
    ev = evidence((0.5, -0.5, 0.2))
    first = plan_write(ev, ZEROS, CIA)
    again = plan_write(ev, first.new_mm, CIA)
    assert again.nothing_to_do and not again.refused
    later = {"x": -0.7, "y": 0.5, "z": -0.2}
    stale = plan_write(ev, later, CIA)
    assert codes(stale) == ["stale"] and "then x +0.0000" in stale.refusals[0].message
    # the new value stays what this campaign says, whatever the controller holds now
    assert stale.new_mm == first.new_mm


def test_restore_plan():
    written = Operation("write-1", "write", "done", ZEROS, {"x": -0.5, "y": 0.5, "z": -0.2},
                        "cia402", nvm_saved=False, wall=None)
    plan = plan_restore(written, written.new_mm, CIA)
    assert plan.new_mm == ZEROS and not plan.refused and plan.restores_operation == "write-1"
    assert plan_restore(written, ZEROS, CIA).nothing_to_do
    stale = plan_restore(written, {"x": -0.6, "y": 0.5, "z": -0.2}, CIA)
    assert codes(stale) == ["stale"]
    assert codes(plan_restore(written, written.new_mm, IAI)) == ["other_profile"]
    # a write that failed half way: some axes still hold the old values, which is expected
    failed = Operation("write-2", "write", "failed", ZEROS, {"x": -0.5, "y": 0.5, "z": -0.2},
                       "cia402", nvm_saved=False, wall=None)
    partial = plan_restore(failed, {"x": -0.5, "y": 0.0, "z": 0.0}, CIA)
    assert not partial.refused and any("did not finish" in n for n in partial.notes)
    saved = Operation("write-3", "write", "done", ZEROS, written.new_mm, "cia402",
                      nvm_saved=True, wall=None)
    assert any("--save-nvm" in n for n in plan_restore(saved, written.new_mm, CIA).notes)


MACHINE = MachineSpec(310.25, -100.0, 60.0, gauge_resolution_mm=0.001,
                      gauge_repeatability_mm=0.001)


def synthetic_fit(effects: dict[str, float], seed: int):
    lay = planned_layout(ProtocolConfig(), MACHINE)
    obs = readings_observations(MACHINE, lay, np.zeros(len(lay)))
    truth = {"joint_offset.x": 0.8, "joint_offset.y": -0.6, "joint_offset.z": 1.2, **effects}
    rng = np.random.default_rng(seed)
    values = obs.predict(vector(truth)[None])[0] + 5.0 + rng.normal(0.0, 0.001, len(lay))
    return fit(readings_observations(MACHINE, lay, values), PARAM_SETS["offsets"])


def test_chi_square_verdict_against_the_gauge_noise():
    # offsets only: chi2 follows its distribution, so the verdict is consistent
    p_values = [fit_verdict(synthetic_fit({}, seed)).p_value for seed in range(20)]
    assert all(p > 0.001 for p in p_values)
    assert 0.1 < float(np.mean(p_values)) < 0.9
    verdict = fit_verdict(synthetic_fit({}, 1))
    assert verdict.consistent and verdict.dof == 63 and verdict.noise.source == "machine file"
    assert verdict.chi2_dof == pytest.approx(1.0, abs=0.4)
    # 0.5 mrad out of square: small, but far above 1 um gauges
    verdict = fit_verdict(synthetic_fit({"squareness.xy": 0.5}, 1))
    assert not verdict.consistent and verdict.chi2_dof > 5
    assert verdict.describe().startswith("NOT within the gauge noise (chi-square test")
    assert "judged at the 0.01 level" in verdict.describe()


def test_a_fit_with_no_redundancy_is_not_called_consistent():
    lay = planned_layout(ProtocolConfig(legs=("x",), postures=("zero", "max"), cycles=1),
                         MACHINE)
    obs = readings_observations(MACHINE, lay, np.zeros(len(lay)))
    verdict = fit_verdict(fit(obs, PARAM_SETS["offsets"]))
    assert verdict.dof <= 0 and not verdict.consistent and verdict.state == "undetermined"
    assert "no redundancy" in verdict.describe()
    assert verdict.to_json()["chi2_dof"] is None


def test_a_restore_cut_half_way_is_finished_even_of_a_done_write():
    """A restore killed after x was put back, y and z not yet: the write it undoes had
    finished, and the axis already back at its old value is no later change (it was
    refused as stale, leaving the controller half restored)."""
    written = Operation("write-1", "write", "done", ZEROS, {"x": -0.5, "y": 0.5, "z": -0.2},
                        "cia402", nvm_saved=False, wall=None)
    half = plan_restore(written, {"x": 0.0, "y": 0.5, "z": -0.2}, CIA)
    assert not half.refused and half.new_mm == ZEROS
