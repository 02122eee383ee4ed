"""The GUM budget: every source on the papers' protocol, hand-computable cases, and
sources that are not evaluated making the budget incomplete."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from ogacq.identify.fit import fit
from ogacq.identify.observations import averaged_deviations, deviations_observations
from ogacq.io.tables import read_deviations
from ogacq.model.parameters import PARAM_SETS
from ogacq.uncertainty.budget import deviation_budget, uncertainty_budget, welch_satterthwaite
from ogacq.uncertainty.inputs import BudgetInputs, standard_uncertainty
from tests.uncertainty.campaigns import papers_campaign

GAUGES = ("y_x", "z_x", "x_y", "z_y", "x_z", "y_z")
CERTIFICATES = {key: standard_uncertainty(0.0015, 2.0) for key in GAUGES}


def full_inputs(result, **more) -> BudgetInputs:
    given = {"calibration_u_mm": CERTIFICATES, "ambient_start_c": 20.4,
             "ambient_end_c": 21.6, "register_step_mm": 0.001, **more}
    return BudgetInputs.from_fit(result, **given)


def test_every_source_on_the_papers_protocol():
    obs, result = papers_campaign()
    assert len(obs) == 72
    budget = uncertainty_budget(obs, result, full_inputs(result))
    assert budget.complete
    assert budget.names == PARAM_SETS["offsets"]
    for out in budget.outputs:
        sources = [row.source for row in out.rows]
        assert sources == ["gauge noise", "display resolution",
                           *(f"gauge calibration {g}" for g in GAUGES),
                           "temperature range", "thermometer", "register rounding"]
        rows = {row.source: row for row in out.rows}
        # the fit's own noise model: scatter and rounding together are its std, exactly
        k = result.names.index(out.name)
        assert math.hypot(rows["gauge noise"].u_mm, rows["display resolution"].u_mm) == \
            pytest.approx(result.std[k], rel=1e-12)
        assert out.u_c == pytest.approx(math.sqrt(sum(r.u_mm**2 for r in out.rows)), rel=1e-12)
        expanded = out.U
        assert expanded == 2.0 * out.u_c
        assert rows["thermometer"].unit == "degC"
        # a common leg growth moves the offsets about one for one: alpha L per degC
        alpha_l = 11.5e-6 * 310.25
        assert abs(rows["thermometer"].sensitivity) == pytest.approx(alpha_l, rel=0.1)
        assert rows["thermometer"].u_mm == pytest.approx(
            abs(rows["thermometer"].sensitivity) * 0.3, rel=1e-12)
        # the mean 21.0 degC is a known effect, stated as a correction to 20 degC
        assert out.temperature_correction_mm == pytest.approx(
            rows["thermometer"].sensitivity * 1.0, rel=1e-12)
        assert all(row.u_mm > 0 and row.evaluated for row in out.rows)
        assert out.dof_eff == math.inf  # stated noise, type B everywhere

    doc = budget.to_json()
    x = doc["results"]["joint_offset"]["x"]
    assert set(x) >= {"value_mm", "u_mm", "U_mm", "k"} and x["k"] == 2.0
    row = doc["budget"]["joint_offset.x"][0]
    assert set(row) >= {"source", "type", "distribution", "u_input", "unit", "sensitivity",
                        "u_mm", "evaluated"}
    assert doc["budget_complete"] is True


def test_register_rounding_alone_is_a_step_over_root_12():
    obs, result = papers_campaign()
    inputs = BudgetInputs(gauge_noise_mm=None, resolution_mm=None, leg_length_mm=310.25,
                          register_step_mm=0.01)
    out = uncertainty_budget(obs, result, inputs)["joint_offset.y"]
    assert out.u_c == 0.01 / math.sqrt(12.0)
    assert not out.complete  # the other sources are unknown, not zero
    assert set(out.not_evaluated) == {"gauge noise", "display resolution", "temperature range",
                                      "thermometer", *(f"gauge calibration {g}" for g in GAUGES)}


def test_tabulated_deviations_by_hand(paper_dir, paper_machine):
    """The papers' table 2: the noise row is the fit's std exactly when given the fit's
    noise; a gauge's calibration acts on a deviation as value / span."""
    obs = deviations_observations(paper_machine,
                                  read_deviations(paper_dir / "experiment2_12.csv"))
    result = fit(obs, PARAM_SETS["offsets"])
    inputs = BudgetInputs(gauge_noise_mm=result.noise.sigma_mm, resolution_mm=None,
                          leg_length_mm=310.25, calibration_u_mm={"x_y": 0.001})
    budget = uncertainty_budget(obs, result, inputs)
    for k, name in enumerate(result.names):
        noise = budget[name].rows[0]
        assert noise.source == "gauge noise"
        assert noise.u_mm == pytest.approx(result.std[k], rel=1e-12)

    deviations = deviation_budget(obs, inputs)
    row = {r.source: r for r in deviations["dx_y+"].rows}["gauge calibration x_y"]
    span = 0.22 - (-0.19)  # dx_y+ = -0.19, dx_y- = 0.22, Zero = 0
    assert row.sensitivity == pytest.approx(-0.19 / span, rel=1e-12)
    assert row.u_mm == pytest.approx(0.001 * 0.19 / span, rel=1e-12)
    other = {r.source: r for r in deviations["dy_x+"].rows}["gauge calibration x_y"]
    assert other.sensitivity == 0.0
    assert not deviations.complete


def test_deviations_from_readings_are_the_papers_averages():
    obs, result = papers_campaign()
    budget = deviation_budget(obs, full_inputs(result))
    reference = averaged_deviations(obs)
    assert list(budget.names) == reference.labels
    assert [o.value_mm for o in budget.outputs] == pytest.approx(reference.values, abs=1e-12)
    assert budget.complete
    # Max minus Zero: the mean of three readings (one per cycle) minus that of six
    # (Zero is read at both ends of every cycle)
    noise = budget["dx_y+"].rows[0]
    assert noise.u_mm == pytest.approx(0.0015 * math.sqrt(1 / 3 + 1 / 6), rel=1e-12)
    doc = budget.to_json()
    assert doc["deviations"]["dx_y+"]["U_mm"] == pytest.approx(budget["dx_y+"].U)
    accept = budget.for_acceptance()
    assert accept["dx_y+"].U_mm == budget["dx_y+"].U


def test_unknown_inputs_are_not_evaluated_never_zero():
    obs, result = papers_campaign()
    certificates = dict(CERTIFICATES, z_y=None)
    del certificates["x_z"]
    inputs = BudgetInputs.from_fit(result, calibration_u_mm=certificates,
                                   ambient_start_c=20.5)  # no end temperature
    budget = uncertainty_budget(obs, result, inputs)
    assert not budget.complete
    out = budget["joint_offset.z"]
    missing = {row.source: row for row in out.rows if not row.evaluated}
    assert set(missing) == {"gauge calibration z_y", "gauge calibration x_z",
                            "temperature range", "thermometer"}
    assert all(row.u_mm is None for row in missing.values())
    assert "temperature at end not recorded" in missing["thermometer"].note
    assert missing["gauge calibration z_y"].sensitivity != 0  # it would matter
    assert out.temperature_correction_mm is None
    assert "register rounding" not in [row.source for row in out.rows]  # nothing written
    doc = budget.to_json()
    assert doc["budget_complete"] is False
    assert doc["results"]["joint_offset"]["z"]["complete"] is False
    z_y = next(r for r in doc["budget"]["joint_offset.z"] if r["source"].endswith("z_y"))
    assert z_y["u_mm"] is None and z_y["evaluated"] is False

    deviations = deviation_budget(obs, inputs).for_acceptance()
    assert deviations["dx_y+"].U_mm is None
    assert "incomplete" in deviations["dx_y+"].why_no_U


def test_paper_table_without_repeats_leaves_the_noise_unevaluated(paper_dir, paper_machine):
    obs = deviations_observations(paper_machine,
                                  read_deviations(paper_dir / "experiment2_12.csv"))
    result = fit(obs, PARAM_SETS["offsets"])
    inputs = BudgetInputs.from_fit(result, calibration_u_mm=CERTIFICATES,
                                   ambient_start_c=20.0, ambient_end_c=20.0)
    out = uncertainty_budget(obs, result, inputs)["joint_offset.x"]
    assert [row.source for row in out.rows if not row.evaluated] == ["gauge noise"]
    temperature = {row.source: row for row in out.rows}["temperature range"]
    assert temperature.evaluated and temperature.u_mm == 0.0  # no change seen


def test_welch_satterthwaite_by_hand():
    # one type A source of 4 dof beside a type B one of equal size: nu = 4 * 4 = 16
    u = math.sqrt(2.0)
    assert welch_satterthwaite(u, [(1.0, 4.0), (1.0, math.inf)]) == pytest.approx(16.0)
    assert welch_satterthwaite(1.0, [(1.0, math.inf)]) == math.inf


def test_measured_noise_is_type_a_with_its_dof():
    obs, _ = papers_campaign()
    machine = replace(obs.machine, gauge_repeatability_mm=None)
    obs2 = type(obs)(machine, obs.layout, obs.values, obs.labels)
    result2 = fit(obs2, PARAM_SETS["offsets"])
    inputs = BudgetInputs.from_fit(result2)
    groups = int(obs.layout.repeat_group.max()) + 1  # postures of a gauge, by approach
    assert inputs.gauge_noise_dof == result2.noise.dof == 72 - groups
    noise = uncertainty_budget(obs2, result2, inputs)["joint_offset.x"].rows[0]
    assert (noise.gum_type, noise.dof) == ("A", float(72 - groups))


@pytest.mark.parametrize(("given", "named"), [
    ({"gauge_noise_mm": -0.001}, "gauge_noise_mm"),
    ({"resolution_mm": 0.0}, "resolution_mm"),
    ({"register_step_mm": -0.01}, "register_step_mm"),
    ({"thermometer_u_c": -0.1}, "thermometer_u_c"),
    ({"leg_expansion_ppm_per_k": -11.5}, "leg_expansion_ppm_per_k"),
    ({"calibration_u_mm": {"y_x": -0.001}}, "calibration_u_mm['y_x']"),
    ({"calibration_u_mm": {"x_x": 0.001}}, "'x_x' is not a gauge"),
    ({"ambient_start_c": 2040.0}, "ambient_start_c"),
    ({"gauge_noise_dof": 0}, "gauge_noise_dof"),
    ({"leg_length_mm": float("nan")}, "leg_length_mm"),
])
def test_bad_inputs_are_refused_by_name(given, named):
    values = {"gauge_noise_mm": 0.001, "resolution_mm": 0.001, "leg_length_mm": 310.25,
              **given}
    with pytest.raises(ValueError, match=__import__("re").escape(named)):
        BudgetInputs(**values)


def test_certificate_uncertainty_is_u_over_k():
    assert standard_uncertainty(0.003, 2.0) == 0.0015
    with pytest.raises(ValueError, match="coverage factor"):
        standard_uncertainty(0.003, 0.0)
    with pytest.raises(ValueError, match="certificate uncertainty"):
        standard_uncertainty(-0.003, 2.0)


def test_a_fit_of_other_observations_is_refused():
    obs, result = papers_campaign()
    other = averaged_deviations(obs)
    with pytest.raises(ValueError, match="72 observations, these are 12"):
        uncertainty_budget(other, result, BudgetInputs.from_fit(result))
    assert np.isfinite(result.std).all()


def test_parameters_not_separately_identifiable_make_the_budget_incomplete(paper_dir,
                                                                           paper_machine):
    """MODEL.md: offsets and lengths together from table 2 are not separately
    identifiable; their spread is stated, but never as a complete budget."""
    obs = deviations_observations(paper_machine,
                                  read_deviations(paper_dir / "experiment2_12.csv"))
    result = fit(obs, PARAM_SETS["both"])
    inputs = BudgetInputs.from_fit(result, gauge_noise_mm=0.003,
                                   calibration_u_mm=CERTIFICATES, ambient_start_c=20.0,
                                   ambient_end_c=20.5)
    budget = uncertainty_budget(obs, result, inputs)
    out = budget["leg_length.y"]
    assert all(row.evaluated for row in out.rows)
    assert not out.identified and not out.complete and not budget.complete
    assert "joint_offset.y/leg_length.y" in out.note
    doc = budget.to_json()["results"]["leg_length"]["y"]
    assert doc["identified"] is False and doc["complete"] is False
    assert doc["u_mm"] == pytest.approx(out.u_c, abs=1e-9) and out.u_c > 0.1
