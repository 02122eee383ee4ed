"""GUM Supplement 1: the Monte-Carlo of the same inputs agrees with the budget's u_c
within 10 % on the papers' protocol, statistically (the MC std's own standard
error included), for a digital indicator and for the papers' 10 um dials, whose
repeats share their rounding."""

from __future__ import annotations

import numpy as np
import pytest

from ogacq.uncertainty.budget import uncertainty_budget
from ogacq.uncertainty.inputs import BudgetInputs, standard_uncertainty
from ogacq.uncertainty.montecarlo import monte_carlo
from tests.uncertainty.campaigns import papers_campaign

GAUGES = ("y_x", "z_x", "x_y", "z_y", "x_z", "y_z")


@pytest.mark.parametrize(("scatter", "step", "params"), [
    (0.0015, 0.001, "offsets"),  # 1 um digital indicators
    (0.002, 0.01, "offsets"),  # the papers' 10 um dials: rounding shared by the cycles
    (0.0015, 0.001, "both"),  # six parameters, ill-conditioned but still linear
])
def test_monte_carlo_agrees_with_the_budget(scatter, step, params):
    obs, result = papers_campaign(scatter_mm=scatter, step_mm=step, params=params)
    inputs = BudgetInputs.from_fit(
        result, calibration_u_mm={g: standard_uncertainty(0.003, 2.0) for g in GAUGES},
        ambient_start_c=20.4, ambient_end_c=23.6, register_step_mm=0.01)
    budget = uncertainty_budget(obs, result, inputs)
    assert all(row.evaluated for out in budget.outputs for row in out.rows)
    assert budget.complete == (params == "offsets")  # the six: correlated beyond 0.99
    mc = monte_carlo(obs, result, inputs, draws=800, seed=11, budget=budget)
    assert mc.converged_fraction == 1.0
    # |ratio - 1| + 1.645 se <= 0.10: within 10 % at 95 % confidence, not by luck
    assert np.all(mc.ratio_se < 0.03)
    assert mc.agrees(0.10), (mc.ratio, mc.ratio_se)
    # the draws' mean sits where the budget's temperature correction puts the value
    correction = np.array([o.temperature_correction_mm for o in budget.outputs])
    se_mean = mc.std / np.sqrt(mc.draws)
    assert np.all(np.abs(mc.mean - result.values - correction) < 4 * se_mean)
    # the 95 % interval: about 2 u either side for these near-normal outputs
    assert np.all((mc.high - mc.low) / (4 * mc.std) == pytest.approx(1.0, abs=0.1))
    doc = mc.to_json()
    assert doc["draws"] == 800 and set(doc["u_mm"]) == set(result.names)
    assert doc["agreement"] == pytest.approx(mc.agreement, abs=1e-4)


def test_a_wrong_budget_is_caught():
    """The check can fail: a budget that leaves the calibration out is too small."""
    obs, result = papers_campaign()
    inputs = BudgetInputs.from_fit(
        result, calibration_u_mm={g: standard_uncertainty(0.01, 2.0) for g in GAUGES})
    understated = uncertainty_budget(
        obs, result, BudgetInputs.from_fit(result, calibration_u_mm={g: 0.0 for g in GAUGES}))
    mc = monte_carlo(obs, result, inputs, draws=400, seed=2, budget=understated)
    assert not mc.agrees()
    assert np.all(mc.ratio > 1.2)


def test_too_few_draws_are_refused():
    obs, result = papers_campaign()
    with pytest.raises(ValueError, match="draws must be at least 10"):
        monte_carlo(obs, result, BudgetInputs.from_fit(result), draws=3)
