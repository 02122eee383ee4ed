"""What an evaluation of the model remembers between calls (issue 14: a refit's fixed
cost) gives exactly what a fresh evaluation gives, and is recomputed when an entry
it read changes: the same doubles, not merely close ones."""

from __future__ import annotations

import numpy as np

from ogacq.model.kinematics import axis_lines, forward, forward_tangent, joint_centres
from ogacq.model.machine import PAPER_PROTOTYPE as M
from ogacq.model.measurement import ReadingsLayout, predict_and_jacobian
from ogacq.model.parameters import PARAM_SETS, indices, vector
from ogacq.protocol.plan import ProtocolConfig, planned_layout

OFFSETS = indices(PARAM_SETS["offsets"])


def fresh_layout() -> ReadingsLayout:
    """A layout no evaluation has seen: its plans start empty."""
    return planned_layout(ProtocolConfig(cycles=2), M)


def evaluate_fresh(theta: np.ndarray, free: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return predict_and_jacobian(theta[None], fresh_layout(), M, free)


def test_remembered_parts_give_the_fresh_evaluations_doubles():
    layout = fresh_layout()
    start = vector({"squareness.xy": 0.3, "backlash.z": 0.02, "gauge_scale.y_x": 200.0,
                    "gauge_position.x": 0.1, "leg_length.y": 0.05})
    for offsets in ([0.0, 0.0, 0.0], [0.4, -0.2, 1.1], [0.41, -0.2, 1.1]):
        theta = start.copy()
        theta[OFFSETS] = offsets
        out, jac = predict_and_jacobian(theta[None], layout, M, OFFSETS)
        fresh_out, fresh_jac = evaluate_fresh(theta, OFFSETS)
        assert np.array_equal(out, fresh_out) and np.array_equal(jac, fresh_jac)


def test_a_changed_fixed_entry_is_not_served_from_memory():
    """An entry outside the free set that changes between calls (another fit's start,
    a diagnosis trying an effect) is read again, whatever it moves: the lines, the
    joint positions' terms, a gauge's position or gain."""
    layout = fresh_layout()
    base = vector({"joint_offset.x": 0.2})
    predict_and_jacobian(base[None], layout, M, OFFSETS)  # remembered for base
    for name, value in (("squareness.xz", 0.5), ("axis_offset.xy", 0.3),
                        ("encoder_scale.y", 80.0), ("backlash.x", 0.03),
                        ("gauge_position.y", -0.2), ("gauge_scale.z_x", 150.0),
                        ("leg_length.z", -0.1)):
        theta = base.copy()
        theta[indices([name])] = value
        out, jac = predict_and_jacobian(theta[None], layout, M, OFFSETS)
        fresh_out, fresh_jac = evaluate_fresh(theta, OFFSETS)
        assert np.array_equal(out, fresh_out), name
        assert np.array_equal(jac, fresh_jac), name
        again = predict_and_jacobian(base[None], layout, M, OFFSETS)[0]
        assert np.array_equal(again, evaluate_fresh(base, OFFSETS)[0]), name


def test_a_caller_changing_its_vector_afterwards_does_not_change_the_memory():
    layout = fresh_layout()
    theta = vector({"squareness.xy": 0.2})[None]
    first = predict_and_jacobian(theta, layout, M, OFFSETS)[0]
    theta[0, indices(["squareness.xy"])] = 0.7  # the caller reuses its array
    moved = predict_and_jacobian(theta, layout, M, OFFSETS)[0]
    assert not np.array_equal(first, moved)
    assert np.array_equal(moved, evaluate_fresh(theta[0], OFFSETS)[0])


def test_no_leg_length_term_is_the_zero_term():
    rng = np.random.default_rng(5)
    theta = vector({"squareness.xy": 0.4, "axis_offset.yz": 0.2})[None]
    u, o = axis_lines(theta)
    rho = 310.25 + rng.uniform(-60, 40, size=(1, 6, 3))
    r = joint_centres(rho, u[:, None], o[:, None])
    legs = np.full((1, 1, 3), 310.25)
    p = forward(r, legs)
    dr = rng.normal(size=(1, 6, 3, 3, 3))
    with_zeros = forward_tangent(r, p, legs, dr, np.zeros((3, 3)))
    assert np.array_equal(forward_tangent(r, p, legs, dr, None), with_zeros)


def test_unique_rows_is_numpys_unique_by_rows() -> None:
    """The layout's groups by one lexsort: the rows, their order and the inverse of
    np.unique(axis=0), on keys with repeats, signed zeros, ties in early columns."""
    from ogacq.model.measurement import unique_rows

    rng = np.random.default_rng(7)
    keys = np.column_stack([rng.integers(0, 3, 500), rng.choice([-0.0, 0.0, 12.5, -3.25], 500),
                            rng.integers(-1, 2, (500, 2)), rng.choice([0.1, 0.2], 500)])
    for rows in (keys, keys[:1], keys[:0].reshape(0, 5)):
        unique, inverse = unique_rows(rows)
        expected, expected_inverse = np.unique(rows, axis=0, return_inverse=True)
        np.testing.assert_array_equal(unique, expected)
        np.testing.assert_array_equal(inverse, expected_inverse.ravel())
        np.testing.assert_array_equal(unique[inverse], rows)
