"""The papers' data (2008, tables 1 and 2) through the diagnosis: experiment 1 is
inconsistent with 0.01 mm gauges; for experiments 2 and 3 the report states what
the six-equation data can and cannot decide, and what would decide it."""

from __future__ import annotations

import pytest

from ogacq.diagnose.diagnosis import diagnose
from ogacq.io.loading import load_observations


def diagnosis(paper_dir, paper_machine, name):
    return diagnose(load_observations(paper_dir / f"{name}.csv", paper_machine))


def test_experiment1_is_inconsistent_with_the_gauges(paper_dir, paper_machine):
    d = diagnosis(paper_dir, paper_machine, "experiment1_6")
    assert d.noise.sigma_mm == pytest.approx(0.01)
    assert d.noise.source == "gauge resolution"
    assert not d.base.consistent
    assert d.base.p_value < 1e-100
    assert d.base.rms_mm == pytest.approx(0.76, abs=0.005)
    # a deviation is a difference of two readings: sigma^2 * 2 per deviation
    assert d.base.chi2_dof == pytest.approx(6 * 0.76**2 / (2 * 0.01**2) / 3, rel=0.02)
    # nothing in the library explains six numbers with 3 dof left: no effect is named
    assert d.outcome == "unexplained"
    assert d.to_json()["effects"][-1]["effect"] == "unexplained"
    assert d.confident() == []


@pytest.mark.parametrize("name", ["experiment1_6", "experiment2_6", "experiment3_6"])
def test_what_six_equations_can_and_cannot_decide(paper_dir, paper_machine, name):
    d = diagnosis(paper_dir, paper_machine, name)
    cap = d.capability
    assert not d.base.consistent  # 0.2 mm residuals against 0.01 mm gauges
    # three numbers are left after the offsets, and the effects fill all three:
    # any three independent effects reproduce the table exactly
    assert cap.dof_after_offsets == 3
    assert cap.effect_rank == 3 and cap.saturated
    # tabulated deviations carry no approach side and no time
    assert {n.split(".")[0] for n in cap.invisible()} == {"backlash", "thermal_drift"}
    # leg lengths hide in the offsets (the papers' rank 5 of 6) ...
    assert all(n in cap.weak() for n in ("leg_length.x", "leg_length.y", "leg_length.z"))
    # ... and several effects are indistinguishable from one another
    groups = cap.alias_groups()
    assert groups and any(len(g) >= 3 for g in groups)
    assert any({"squareness.xy", "gauge_position.z"} <= set(g) for g in groups)
    # no effect is named with confidence on such data
    assert d.confident() == []
    # the raw readings of the papers' protocol would decide: 63 dof after the
    # offsets, every effect seen, no alias left
    plans = {option.key: plan for option, plan in d.plans}
    raw = plans["readings"]
    assert raw.dof_after_offsets == 63
    assert raw.invisible() == [] and raw.alias_groups() == []
    assert raw.effect_rank > cap.effect_rank


@pytest.mark.parametrize("name", ["experiment2_12", "experiment3_12"])
def test_twelve_deviations_see_more_but_not_drives(paper_dir, paper_machine, name):
    d = diagnosis(paper_dir, paper_machine, name)
    cap = d.capability
    assert not d.base.consistent
    assert cap.dof_after_offsets == 9 and cap.alias_groups() == []
    assert {n.split(".")[0] for n in cap.invisible()} == {"backlash", "thermal_drift"}
    # at these deviations no single effect or pair brings the fit within the noise
    # with plausible values: the tool names none
    assert d.outcome == "unexplained"
    assert d.confident() == []


def test_experiment3_offsets_match_the_refit(paper_dir, paper_machine):
    """The base model of the diagnosis is the papers' offsets fit (GLS on the exact
    model; the six-equation covariance is 2 I, so GLS is OLS)."""
    d = diagnosis(paper_dir, paper_machine, "experiment3_6")
    offsets = d.to_json()["parameters"]["joint_offset"]
    assert [offsets[a] for a in "xyz"] == pytest.approx([0.07, 0.14, 0.00], abs=0.01)
