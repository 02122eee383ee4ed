import numpy as np

from ogacq.identify.accuracy import planned_observations, predict_accuracy
from ogacq.model.machine import PAPER_PROTOTYPE
from ogacq.model.parameters import PARAM_SETS


def test_monte_carlo_of_the_nonlinear_fit_agrees_with_the_analytic_std():
    obs = planned_observations(PAPER_PROTOTYPE, postures=("zero", "max", "min", "zero"),
                               cycles=3)
    truth = {"joint_offset.x": 1.5, "joint_offset.y": -0.8, "joint_offset.z": 2.0}
    pred = predict_accuracy(obs, PARAM_SETS["offsets"], 0.01, truth=truth, trials=3000,
                            seed=4, rounding_mm=0.001)
    assert pred.converged_fraction == 1.0
    assert np.allclose(pred.mc_std, pred.analytic_std, rtol=0.08)
    assert np.all(np.abs(pred.mc_bias) < 3 * pred.analytic_std / np.sqrt(3000) + 2e-4)
    assert pred.identifiability.identifiable


def test_more_cycles_shrink_the_std_as_the_square_root():
    one = predict_accuracy(planned_observations(PAPER_PROTOTYPE, postures=(
        "zero", "max", "min", "zero"), cycles=1), PARAM_SETS["offsets"], 0.01)
    four = predict_accuracy(planned_observations(PAPER_PROTOTYPE, postures=(
        "zero", "max", "min", "zero"), cycles=4), PARAM_SETS["offsets"], 0.01)
    assert np.allclose(one.analytic_std / four.analytic_std, 2.0, rtol=1e-6)


def test_plan_says_lengths_and_offsets_cannot_be_separated():
    obs = planned_observations(PAPER_PROTOTYPE, postures=("zero", "max", "min", "zero"),
                               cycles=3)
    pred = predict_accuracy(obs, PARAM_SETS["both"], 0.01)
    assert not pred.identifiability.identifiable
    assert len(pred.identifiability.correlated_pairs) == 3


def test_a_watched_monte_carlo_draws_the_same_trials():
    """A progress watcher makes the batches smaller, never other draws."""
    obs = planned_observations(PAPER_PROTOTYPE, postures=("zero", "max", "min", "zero"),
                               cycles=3)
    told: list[tuple[int, int]] = []
    kwargs = dict(trials=300, seed=3, rounding_mm=0.01)
    quiet = predict_accuracy(obs, PARAM_SETS["offsets"], 0.01, **kwargs)
    watched = predict_accuracy(obs, PARAM_SETS["offsets"], 0.01,
                               on_trials=lambda done, total: told.append((done, total)),
                               **kwargs)
    assert told[-1] == (300, 300) and len(told) > 1
    assert [d for d, _ in told] == sorted(d for d, _ in told)
    np.testing.assert_allclose(watched.mc_std, quiet.mc_std, rtol=1e-9)
    np.testing.assert_allclose(watched.mc_bias, quiet.mc_bias, rtol=1e-9, atol=1e-12)


def test_trials_that_run_off_along_an_unbounded_direction_are_left_out_and_counted():
    """A travel of +-2 mm leaves the offsets and the lengths free to grow together
    (the exact model's legs lengthen without bound, the cost still falling): trials
    ran to 1e12 mm and made the Monte-Carlo std 1e12 mm. They are counted apart; the
    std of the rest stays within what a machine could have, and the JSON has no NaN."""
    import json

    from ogacq.model.machine import MachineSpec

    narrow = MachineSpec(310.25, -2.0, 1.5, gauge_resolution_mm=0.001,
                         gauge_repeatability_mm=0.002)
    obs = planned_observations(narrow, postures=("zero", "max", "min", "zero"), cycles=3)
    pred = predict_accuracy(obs, PARAM_SETS["both"], 0.002, trials=300, rounding_mm=0.001)
    assert not pred.identifiability.identifiable
    assert np.all(np.abs(pred.mc_std) < 100 * 10.0) and np.all(np.abs(pred.mc_bias) < 1000)
    assert pred.ran_off_fraction is not None and 0 < pred.ran_off_fraction < 1
    assert pred.converged_fraction <= 1 - pred.ran_off_fraction
    json.dumps(pred.to_json(), allow_nan=False)
