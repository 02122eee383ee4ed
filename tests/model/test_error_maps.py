"""The joint-level pieces of the error maps: each reading's sensitivity to the joint
centres (against the model's own Jacobian), a displaced evaluation (against the
first order), the travel since a reversal and the approach side (against plain
loops), the spline basis (against scipy), the families' shapes and the AxisMap
tables made from them; the simulator's effects file and its axes' reversals."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.interpolate import BSpline

from ogacq_drivers.sim.clock import SimClock
from ogacq_drivers.sim.motion import MotionModel
from ogacq.errors import InputError
from ogacq.model.error_maps import (
    NO_SPREAD,
    JointHistory,
    MapTerm,
    ShapeSpread,
    axis_map,
    cubic_bspline,
    travel_since_reversal,
)
from ogacq.model.joint_sensitivity import joint_sensitivity, predict_displaced
from ogacq.model.measurement import approach_from_sequence, predict_coordinates, predict_jacobian
from ogacq.model.parameters import indices, vector
from ogacq.sim.truth import random_truth, read_effects
from tests.diagnose.campaigns import MACHINE, OFFSETS, layout


def approach_by_loop(q_mm: np.ndarray) -> np.ndarray:
    """The former row-by-row definition, kept as the reference."""
    out = np.zeros(q_mm.shape, dtype=int)
    last = np.zeros(3, dtype=int)
    prev = q_mm[0] if len(q_mm) else None
    for k, q in enumerate(q_mm):
        step = np.sign(np.round(q - prev, 9)).astype(int)
        last = np.where(step != 0, step, last)
        out[k] = last
        prev = q
    return out


def test_approach_from_sequence_is_the_loop_it_replaces():
    rng = np.random.default_rng(1)
    # steps at the rounding's edges too: half a nanometre and its neighbours
    choices = [0.0, 0.0, 1e-3, -2.0, 5e-10, -5e-10, 4.9e-10, 5.1e-10, 1e-9,
               float(np.nextafter(5e-10, 1))]
    for _ in range(300):
        n = int(rng.integers(0, 40))
        q = np.cumsum(rng.choice(choices, size=(n, 3)), axis=0) + rng.normal(size=3) * 100
        assert np.array_equal(approach_from_sequence(q), approach_by_loop(q))
    scan = layout(scan_step_mm=2.0, cycles=2).q_mm
    assert np.array_equal(approach_from_sequence(scan), approach_by_loop(scan))


def travel_by_loop(q: np.ndarray, side: np.ndarray, overshoot: float) -> np.ndarray:
    n = len(q)
    out = np.full((n, 3), np.inf)
    for a in range(3):
        travel, started = np.inf, False
        for k in range(1, n):
            move = q[k, a] - q[k - 1, a]
            direction = int(np.sign(np.round(move, 9)))
            if direction and direction != side[k, a] or not direction and \
                    side[k, a] != side[k - 1, a]:
                travel, started = overshoot, True  # a reversal hidden in an approach
            elif side[k, a] != side[k - 1, a]:
                travel, started = abs(move), True  # reversed at the last reading
            else:
                travel += abs(move)
            out[k, a] = travel if started and side[k, a] else np.inf
    return out


@pytest.mark.parametrize("approach", ["sequence", "both", "from_below", "from_above"])
def test_travel_since_reversal_is_a_walk_along_the_readings(approach):
    for postures in (("zero", 50.0, -90.0, "zero"),
                     ("zero", 30.0, 50.0, 30.0, "zero", -50.0, -90.0, -50.0, "zero")):
        lay = layout(postures, approach=approach, overshoot_mm=2.0)
        ours = travel_since_reversal(lay.q_mm, lay.approach, 2.0)
        theirs = travel_by_loop(lay.q_mm, lay.approach, 2.0)
        assert np.array_equal(np.isinf(ours), np.isinf(theirs))
        assert np.allclose(ours[np.isfinite(ours)], theirs[np.isfinite(theirs)])
    scan = layout(scan_step_mm=5.0)
    travel = travel_since_reversal(scan.q_mm, scan.approach)
    up = (scan.leg == 0) & (scan.approach[:, 0] > 0)
    assert travel[up, 0].min() == 5.0  # one step after each turn at an end


def test_cubic_bspline_is_scipys():
    knots = np.linspace(-100.0, 60.0, 6)
    x = np.linspace(-100.0, 60.0, 97)
    padded = np.concatenate([[knots[0]] * 3, knots, [knots[-1]] * 3])
    theirs = BSpline.design_matrix(x, padded, 3).toarray().T
    assert np.allclose(cubic_bspline(x, knots), theirs, atol=1e-14)


def test_joint_sensitivity_is_the_models_jacobian():
    """Along each line it sums to the joint offset's column (reading and setting
    pose), across to the axis offset's (that shift a line along another axis)."""
    lay = layout(scan_step_mm=20.0)
    theta = vector({**OFFSETS, "squareness.xy": 0.3, "gauge_scale.y_x": 300.0,
                    "backlash.x": 0.01, "thermal_drift.y": 0.1, "gauge_position.x": 0.48})
    sens = joint_sensitivity(theta, lay, MACHINE)
    names = ["joint_offset.x", "joint_offset.y", "joint_offset.z", "axis_offset.xy",
             "axis_offset.xz", "axis_offset.yz"]
    jac = predict_jacobian(theta[None], lay, MACHINE, indices(names))[0]
    reading, setting = sens.along()
    assert np.allclose(reading + setting, jac[:, :3], atol=1e-12)
    for k, (joint, coordinate) in enumerate([(1, 2), (2, 1), (2, 0)]):
        at_reading, at_setting = sens.across(joint, coordinate)
        assert np.allclose(at_reading + at_setting, jac[:, 3 + k], atol=1e-12)


def test_a_displaced_evaluation_is_the_model_and_its_first_order():
    lay = layout(scan_step_mm=20.0)
    theta = vector(OFFSETS)
    n, gauges = len(lay), lay.n_gauges
    still = predict_displaced(theta, lay, MACHINE, np.zeros((n, 3, 3)), np.zeros((gauges, 3, 3)))
    assert np.array_equal(still, predict_coordinates(theta, lay, MACHINE))
    rng = np.random.default_rng(0)
    moved, moved0 = rng.normal(size=(n, 3, 3)) * 0.003, rng.normal(size=(gauges, 3, 3)) * 0.003
    exact = predict_displaced(theta, lay, MACHINE, moved, moved0)
    sens = joint_sensitivity(theta, lay, MACHINE)
    first = still + np.einsum("nac,nac->n", sens.at_reading, moved) + \
        np.einsum("nac,nac->n", sens.at_setting, moved0[lay.gauge])
    assert np.max(np.abs(exact - still)) > 1e-3  # it moved
    assert np.max(np.abs(exact - first)) < 1e-6  # second order of 3 um over 300 mm legs


def test_hysteresis_of_zero_length_is_the_librarys_backlash():
    lay = layout(("zero", 50.0, -90.0, "zero"))
    history = JointHistory.of(lay)
    term = MapTerm("hysteresis", 0, {"length_mm": 0.0})
    shape, _ = term.columns(history)
    # the library's lost motion moves the joint by -side b / 2: the same up to a constant
    assert np.allclose(shape[0] - 0.5, -0.5 * lay.approach[:, 0])
    wound = MapTerm("hysteresis", 0, {"length_mm": 1e-6}).columns(history)[0]
    assert np.allclose(wound, shape)


def test_axis_maps_from_terms():
    cyclic = MapTerm("lead_screw_cyclic", 0, {"pitch_mm": 5.0})
    lag = MapTerm("hysteresis", 0, {"length_mm": 3.0})
    coefficients = [np.array([0.004, 0.002]), np.array([0.02])]
    table = axis_map([cyclic, lag], coefficients, np.eye(3) * 1e-8, -100.0, 60.0, 0.25,
                     source="test", spreads=[ShapeSpread(0.01), NO_SPREAD])
    q = np.array(table.positions_mm)
    assert q[0] == -100.0 and q[-1] == 60.0 and 0.0 in q
    assert table.error_mm(0.0, 1) == pytest.approx(0.0, abs=1e-15)  # zero forward at 0
    expected = 0.004 * np.sin(2 * np.pi * q / 5.0) + 0.002 * (np.cos(2 * np.pi * q / 5.0) - 1)
    assert np.allclose(table.forward_mm, expected)
    assert np.allclose(np.array(table.reverse_mm) - table.forward_mm, 0.02)  # lost motion
    u = np.array(table.u_forward_mm)
    assert u[0] > u[len(q) // 2]
    # at the reference only what the grid leaves between its points (the chord of a
    # 4.5 µm sine at 20 points a period, 1.2 %, as a rectangular bound / sqrt(3))
    chord = np.hypot(0.004, 0.002) * (1 - np.cos(np.pi / 20)) / np.sqrt(3)
    assert 0.0 < u[q == 0.0][0] <= chord * 1.01


def test_the_band_holds_what_the_maps_own_grid_leaves_between_its_points():
    """Linear between its points, a tabulated map misses its terms by the most at the
    middles: the band holds that (beside the reference, where it held nothing, a 6 µm
    lead's 1.2 % chord was the whole error). A smooth map's grid leaves next to
    nothing."""
    cyclic = MapTerm("lead_screw_cyclic", 0, {"pitch_mm": 5.0})
    c = np.array([0.006, 0.0])
    coarse = axis_map([cyclic], [c], np.zeros((2, 2)), -20.0, 20.0, 0.5, source="t")
    q = np.linspace(-20.0, 20.0, 4001)
    left = np.abs(0.006 * np.sin(2 * np.pi * q / 5.0) - np.interp(q, coarse.positions_mm,
                                                                     coarse.forward_mm))
    u = np.interp(q, coarse.positions_mm, coarse.u_forward_mm)
    assert left.max() > 1e-4 and np.all(left <= np.sqrt(3) * u + 1e-12)
    bend = MapTerm("screw_map", 0, {"from_mm": -20.0, "to_mm": 20.0, "knots": 0,
                                    "detrended": 0.0})
    smooth = axis_map([bend], [np.array([0.001, 0.0, 0.0])], np.zeros((3, 3)), -20.0,
                      20.0, 0.5, source="t")
    assert max(smooth.u_forward_mm) < 1e-3 * max(map(abs, smooth.forward_mm))


def test_a_pitchs_error_turns_the_map_about_where_its_path_holds_it():
    """Refitted along its profile, a cyclic term's coefficients move with its pitch so
    that the map stays where the readings hold it: there the pitch's std adds nothing,
    while taken as still it would slip by the distance from the reference."""
    cyclic = MapTerm("lead_screw_cyclic", 0, {"pitch_mm": 5.0})
    c = np.array([0.004, 0.002])
    held = np.array([-60.0])
    slope = cyclic.kind.shape_slope(cyclic, c, held)
    shapes = cyclic.shape_of(held, np.ones(1), np.full(1, np.inf), np.zeros(1))[:, 0]
    path = -slope[0] * shapes / (shapes @ shapes)  # the least change that holds it there

    def band(spread: ShapeSpread) -> np.ndarray:
        table = axis_map([cyclic], [c], np.eye(2) * 1e-12, -100.0, 60.0, 0.25, source="t",
                         spreads=[spread])
        return np.interp(held, table.positions_mm, table.u_forward_mm)

    still, turned = band(ShapeSpread(0.01)), band(ShapeSpread(0.01, path))
    grid = band(NO_SPREAD)  # what the table's own grid leaves there, the pitch aside
    assert still[0] > 1e-4 and turned[0] - grid[0] < 1e-3 * still[0], (still, turned, grid)


def test_effects_file_takes_the_axis_errors(tmp_path: Path):
    path = tmp_path / "effects.toml"
    path.write_text("[lead_screw.x]\namplitude_mm = 0.005\npitch_mm = 5\nphase_deg = 30\n"
                    "[screw_map.y]\ncoefficients_mm = [0.0, 0.0, 0.004]\n"
                    "[rail_bow.z]\ntoward = \"x\"\nsagitta_mm = 0.008\n"
                    "[hysteresis.x]\nlost_motion_mm = 0.02\nbuild_up_mm = 6\n"
                    "[warm_up.y]\noffset_mm = 0.01\ntime_constant_s = 1800\n")
    truth = read_effects(path, random_truth(1))
    assert truth.lead_screw[0].phase_deg == 30.0
    assert truth.screw_map[1].coefficients_mm == (0.0, 0.0, 0.004)
    assert truth.rail_bow[2].toward == "x" and truth.hysteresis[0].build_up_mm == 6.0
    assert truth.warm_up[1].time_constant_s == 1800.0
    q = np.array([[10.0, -50.0, 20.0]])
    moved = truth.disturbed_q(q, np.array([[1, 1, 1]]), np.array([[np.inf] * 3]), 1800.0)
    assert moved[0, 0] == pytest.approx(10.0 + 0.005 * np.sin(2 * np.pi * 2 + np.pi / 6) - 0.01)
    assert moved[0, 1] == pytest.approx(-50.0 + 0.004 * (-0.5) ** 3 + 0.01 * (1 - np.exp(-1)))
    path.write_text("[rail_bow.z]\ntoward = \"z\"\nsagitta_mm = 0.008\n")
    with pytest.raises(InputError, match="toward must be another axis"):
        read_effects(path, random_truth(1))


def test_the_simulated_axes_know_their_travel_since_a_reversal():
    clock = SimClock()
    motion = MotionModel(clock, speed_mm_s=1e6, accel_mm_s2=1e9, settle_s=0.0)
    motion.set_servo("x", True)
    assert motion.travel_since_reversal_mm("x") == float("inf")
    for target in (10.0, 4.0, 7.5):
        motion.move_to("x", target)
        clock.advance(1.0)
    assert motion.travel_since_reversal_mm("x") == pytest.approx(3.5)  # reversed at 4
    motion.move_to("x", 9.0)
    clock.advance(1.0)
    assert motion.travel_since_reversal_mm("x") == pytest.approx(5.0)


def test_a_layout_side_moves_the_lost_motion_not_the_repeat_groups():
    lay = layout(("max", "min", "zero", "max"))
    side = lay.approach.copy()
    side[:2] = -side[:2]
    other = replace(lay, side=side)
    assert np.array_equal(other.repeat_group, lay.repeat_group)
    theta = vector({**OFFSETS, "backlash.x": 0.03})
    moved = predict_coordinates(theta, other, MACHINE) - predict_coordinates(theta, lay, MACHINE)
    assert np.any(np.abs(moved[:2]) > 1e-4) and np.allclose(moved[2:], 0.0)
