from dataclasses import replace

import numpy as np
import pytest

from ogacq.identify.linear import LINEAR_COLUMNS, design_matrix
from ogacq.identify.observations import PAPER_ORDER_12, deviations_observations
from ogacq.model.machine import PAPER_PROTOTYPE as M
from ogacq.model.measurement import ReadingsLayout, predict_coordinates, predict_jacobian
from ogacq.model.parameters import NOMINAL, PARAM_NAMES, effect_of, vector
from ogacq.protocol.plan import ProtocolConfig, planned_layout


def deviations_at(theta):
    obs = deviations_observations(M, [(n, 0.0) for n in PAPER_ORDER_12])
    return obs.predict(theta)


def test_nominal_machine_reads_constant_on_every_gauge():
    layout = planned_layout(ProtocolConfig(), M)
    y = predict_coordinates(vector(), layout, M)
    for g in range(layout.n_gauges):
        assert np.ptp(y[layout.gauge == g]) < 1e-9


def test_exact_jacobian_at_nominal_is_the_papers_eq11():
    J = design_matrix(PAPER_ORDER_12, M)
    h = 1e-5
    for k, name in enumerate(LINEAR_COLUMNS):
        col = (deviations_at(vector({name: h})) - deviations_at(vector({name: -h}))) / (2 * h)
        assert np.allclose(col, J[:, k], atol=1e-8), name


@pytest.mark.parametrize("seed", range(5))
def test_linear_model_agrees_with_exact_to_second_order(seed):
    rng = np.random.default_rng(seed)
    direction = rng.normal(size=6)
    J = design_matrix(PAPER_ORDER_12, M)
    errors = []
    for eps in (0.4, 0.2, 0.1):
        x = eps * direction
        exact = deviations_at(vector(dict(zip(LINEAR_COLUMNS, x, strict=True))))
        errors.append(np.max(np.abs(exact - J @ x)))
    # halving the parameters quarters the linearisation error
    assert 3.0 < errors[0] / errors[1] < 5.0
    assert 3.0 < errors[1] / errors[2] < 5.0
    assert errors[2] < 1e-3


def test_every_effect_moves_some_reading():
    layout = planned_layout(ProtocolConfig(), M)  # approach from the sequence: both sides occur
    start = {"joint_offset.x": 1.0, "joint_offset.y": -1.0, "leg_length.z": 0.5}
    base_theta = vector(start)
    base = predict_coordinates(base_theta, layout, M)
    for k, name in enumerate(PARAM_NAMES):
        theta = base_theta.copy()
        theta[k] += {"fraction": 0.1, "ppm": 1000.0}.get(effect_of(name).unit, 1.0)
        changed = np.max(np.abs(predict_coordinates(theta, layout, M) - base))
        assert changed > 1e-6, f"{name} changes nothing"


def test_batch_prediction_equals_one_at_a_time():
    layout = planned_layout(ProtocolConfig(cycles=1), M)
    rng = np.random.default_rng(3)
    thetas = np.array([vector({"joint_offset.x": a, "squareness.xy": b, "backlash.y": c})
                       for a, b, c in rng.normal(size=(4, 3))])
    batch = predict_coordinates(thetas, layout, M)
    for k in range(4):
        assert np.allclose(batch[k], predict_coordinates(thetas[k], layout, M), atol=1e-12)


def test_subset_keeps_each_gauges_setting_posture():
    layout = planned_layout(ProtocolConfig(), M)
    theta = vector({"joint_offset.x": 2.0, "joint_offset.y": -1.5, "leg_length.z": 0.8})
    full = predict_coordinates(theta, layout, M)
    keep = np.ones(len(layout), dtype=bool)
    keep[:2] = False  # the Zero readings the x-leg gauges were set at
    part = layout.subset(keep)
    assert np.allclose(predict_coordinates(theta, part, M), full[keep], atol=1e-12)
    assert part.n_gauges == layout.n_gauges


@pytest.mark.parametrize("seed", range(3))
def test_analytic_jacobian_matches_central_differences(seed):
    """Every effect nonzero (drift included, so each reading is its own pose), and
    again with drift zero (poses shared, drift's derivative scaled per reading)."""
    rng = np.random.default_rng(seed)
    layout = planned_layout(ProtocolConfig(), M)
    layout = replace(layout, t_s=np.linspace(0.0, 1800.0, len(layout)))
    ranges = np.array([effect_of(n).plausible_range for n in PARAM_NAMES])
    signs = rng.choice([-1.0, 1.0], len(ranges))
    with_drift = NOMINAL + signs * rng.uniform(0.01, 0.1, len(ranges)) * ranges
    without_drift = with_drift.copy()
    without_drift[[PARAM_NAMES.index(f"thermal_drift.{a}") for a in "xyz"]] = 0.0
    free = np.arange(len(PARAM_NAMES))
    for theta in (with_drift, without_drift):
        jac = predict_jacobian(theta[None], layout, M, free)[0]
        for k, name in enumerate(PARAM_NAMES):
            h = ranges[k] * 1e-5
            up, down = theta.copy(), theta.copy()
            up[k] += h
            down[k] -= h
            fd = (predict_coordinates(up, layout, M) - predict_coordinates(down, layout, M)) \
                / (2 * h)
            scale = np.max(np.abs(fd))
            assert scale > 0, name
            assert np.max(np.abs(jac[:, k] - fd)) < 1e-6 * scale, name


def test_analytic_jacobian_of_a_batch_equals_one_at_a_time():
    layout = planned_layout(ProtocolConfig(), M)
    thetas = np.stack([vector({"joint_offset.x": 0.5, "squareness.xy": 1.0}),
                       vector({"leg_length.z": -0.3, "backlash.y": 0.02})])
    free = np.array([PARAM_NAMES.index(n) for n in ("joint_offset.x", "squareness.yz",
                                                    "gauge_scale.y_x", "backlash.y")])
    batch = predict_jacobian(thetas, layout, M, free)
    for b in range(2):
        assert np.allclose(batch[b], predict_jacobian(thetas[b:b + 1], layout, M, free)[0],
                           rtol=0, atol=1e-15)


def test_layout_numbers_gauges_in_order_of_first_reading():
    rng = np.random.default_rng(3)
    leg = rng.integers(0, 3, 200)
    axis = (leg + rng.integers(1, 3, 200)) % 3
    q = rng.normal(size=(200, 3))
    layout = ReadingsLayout.build(q, leg, axis)
    seen: list[tuple[int, int]] = []
    for k in range(200):
        key = (int(axis[k]), int(leg[k]))
        if key not in seen:
            seen.append(key)
            assert np.array_equal(layout.setting_q_mm[len(seen) - 1], q[k])
        assert layout.gauge[k] == seen.index(key)
    assert layout.gauge_keys == tuple(seen)
