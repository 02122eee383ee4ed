import numpy as np

from ogacq.model.kinematics import (
    axis_lines,
    forward,
    inverse,
    joint_centres,
    leg_lengths,
    nominal_q,
    nominal_tcp,
)
from ogacq.model.machine import PAPER_PROTOTYPE as M
from ogacq.model.parameters import vector

L = M.leg_length_mm


def workspace_q(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.uniform(M.rho_min_mm, M.rho_max_mm, (n, 3))


def test_zero_posture_is_the_origin():
    assert np.allclose(nominal_tcp(np.zeros(3), L), 0.0, atol=1e-12)
    assert np.allclose(nominal_q(np.zeros(3), L), 0.0, atol=1e-12)


def test_paper_max_posture_retracts_other_joints():
    q = nominal_q(np.array([60.0, 0, 0]), L)
    alpha = np.arcsin(60.0 / L)
    assert np.allclose(q, [60.0, -L * (1 - np.cos(alpha)), -L * (1 - np.cos(alpha))])


def test_ik_of_fk_is_identity_nominal_across_workspace():
    q = workspace_q(5000)
    p = nominal_tcp(q, L)
    assert np.all(np.isfinite(p))
    assert np.max(np.abs(nominal_q(p, L) - q)) < 1e-9


def test_ik_of_fk_is_identity_with_offsets_lengths_and_effects():
    theta = vector({"joint_offset.x": 0.8, "joint_offset.y": -1.2, "joint_offset.z": 2.0,
                    "leg_length.x": 0.4, "leg_length.y": -0.3, "leg_length.z": 1.1,
                    "squareness.xy": 0.7, "squareness.xz": -0.4, "squareness.yz": 0.3,
                    "axis_offset.xy": 0.2, "axis_offset.xz": -0.5, "axis_offset.yz": 0.1})
    u, o = axis_lines(theta)
    legs = leg_lengths(theta, L)
    rho = L + workspace_q(5000, seed=1)
    p = forward(joint_centres(rho, u, o), np.broadcast_to(legs, rho.shape))
    assert np.all(np.isfinite(p))
    back = inverse(p, u, o, legs)
    assert np.max(np.abs(back - rho)) < 1e-9
    # every leg really has its length
    r = joint_centres(rho, u, o)
    assert np.allclose(np.linalg.norm(p[:, None, :] - r, axis=-1), legs, atol=1e-9)


def test_fk_picks_the_origin_side_assembly_mode():
    p = nominal_tcp(workspace_q(200, seed=2), L)
    # the papers' prototype: TCP stays well inside the cube around the origin
    assert np.all(np.abs(p) < L / 2)


def test_unreachable_posture_is_nan():
    p = nominal_tcp(np.array([L * 3, L * 3, L * 3]), L)
    assert np.all(np.isnan(p))


def test_squareness_is_the_angle_defect():
    u, _ = axis_lines(vector({"squareness.xy": 2.0, "squareness.xz": -1.0}))
    angle_xy = np.degrees(np.arccos(u[0] @ u[1]))
    angle_xz = np.degrees(np.arccos(u[0] @ u[2]))
    assert np.isclose(90.0 - angle_xy, np.degrees(2e-3))
    assert np.isclose(90.0 - angle_xz, np.degrees(-1e-3))
