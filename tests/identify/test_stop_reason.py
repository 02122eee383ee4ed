"""The fit says why it stopped: converged by its step or its cost, out of iterations,
or a step the model could not evaluate; and only the first kind counts as converged."""

import numpy as np

from ogacq.identify import fit as fit_module
from ogacq.identify.fit import StopReason, evaluate, fit
from ogacq.identify.observations import Observations
from ogacq.model.parameters import PARAM_SETS
from tests.identify.test_recovery import simulate

TRUTH = {"joint_offset.x": 3.0, "joint_offset.y": -2.5, "joint_offset.z": 1.7}
OFFSETS = PARAM_SETS["offsets"]


def test_a_fit_that_converges_says_by_what():
    noisy = fit(simulate(TRUTH, 0), OFFSETS)
    assert noisy.converged and noisy.stop_reason in (
        StopReason.STEP_BELOW_TOLERANCE, StopReason.NEGLIGIBLE_STEP, StopReason.COST_STALLED)
    assert noisy.stop_reason.describe().startswith("converged: ")
    assert fit(simulate(TRUTH, 0), OFFSETS, method="linear").stop_reason \
        is StopReason.LINEAR_STEP
    assert evaluate(simulate(TRUTH, 0), OFFSETS, noisy.values).stop_reason \
        is StopReason.EVALUATED


def test_out_of_iterations_is_not_converged(monkeypatch):
    monkeypatch.setattr(fit_module, "MAX_ITERATIONS", 1)  # 3 mm from nominal: several
    result = fit(simulate(TRUTH, 0, noise=0.0), OFFSETS)
    assert result.stop_reason is StopReason.MAX_ITERATIONS and not result.converged
    assert result.iterations == 1


def test_a_step_the_model_cannot_evaluate_is_not_taken_for_the_minimum(monkeypatch):
    """Every trial's predictions non-finite (the legs cannot reach): before, the fit
    said converged where it started."""
    real = Observations.predict_and_jacobian
    calls = []

    def unreachable_beyond_the_start(self, theta, free):
        pred, jac = real(self, theta, free)
        calls.append(theta)
        return (pred if len(calls) == 1 else np.full_like(pred, np.nan)), jac

    monkeypatch.setattr(Observations, "predict_and_jacobian", unreachable_beyond_the_start)
    result = fit(simulate(TRUTH, 0), OFFSETS)
    assert result.stop_reason is StopReason.STEP_FAILED and not result.converged
    assert len(calls) == 1 + fit_module.HALVINGS
    assert "could not be evaluated" in result.stop_reason.describe()
