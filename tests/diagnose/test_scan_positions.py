"""What a scan's positions allow: a dense scan's candidate fits evaluate the model at
nodes along each scanned track (``diagnose/posenodes.py``), what they change of the
predictions interpolated to within a nanometre, a campaign no denser than the nodes
evaluated as before; irregular positions resolve shorter pitches than their mean
step (``mapbins.alias_pitch_mm``)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from ogacq.diagnose.batchfit import Problem, fit_many
from ogacq.diagnose.library import BASE_MODEL, EFFECT_PARAMETERS
from ogacq.diagnose.mapbins import alias_pitch_mm
from ogacq.diagnose.mapsearch import (
    AxisCoverage,
    _Families,
    _grid_functions,
    _trial_functions,
    coverage,
)
from ogacq.diagnose.mapspace import MapSpace
from ogacq.diagnose.posenodes import pose_nodes
from ogacq.identify.fit import fit
from ogacq.model.families import FAMILIES
from ogacq.model.families.smooth import KNOTS
from ogacq.model.measurement import predict_coordinates
from ogacq.model.parameters import PARAM_INDEX
from ogacq.sim.truth import ScrewMap
from tests.diagnose.test_maps import campaign

CHANGES = {"squareness.xy": 0.5, "backlash.z": 0.02, "joint_offset.x": 0.01,
           "leg_length.y": 0.05, "gauge_position.x": 0.1, "encoder_scale.z": 100.0}


def test_a_dense_scan_is_evaluated_at_nodes_to_within_a_nanometre():
    obs, _ = campaign(1, scan={"scan_step_mm": 0.1, "cycles": 1})
    space = Problem(obs).group_space
    assert space is not None
    nodes = space._nodes
    assert nodes is not None and len(nodes.nodes) * 4 < len(space)
    start = fit(obs, BASE_MODEL, method="exact", weighting="gls").theta
    exact_start = space.start_at(start)  # exact, the reference
    rng = np.random.default_rng(0)
    batch = np.repeat(start[None], 6, axis=0)
    for name, size in CHANGES.items():
        batch[:, PARAM_INDEX[name]] += rng.normal(0, size, len(batch))
    exact = predict_coordinates(batch, space.layout, obs.machine)
    assert np.abs(space._predicted(batch) - exact).max() < 1e-6  # mm
    # the residual coordinates of the batch, interpolated, beside the exact ones
    r = space.residuals(batch)
    assert np.allclose(np.sum(r**2, axis=1),
                       np.sum(space._project((space._mean - exact) * space._scale) ** 2, axis=1),
                       rtol=1e-4)
    assert np.allclose(space.residuals(start[None])[0], exact_start, rtol=0, atol=1e-12)


def test_a_scan_no_denser_than_the_nodes_is_evaluated_at_every_group():
    obs, _ = campaign(1)  # a 1 mm scan
    assert pose_nodes(Problem(obs).group_space.layout) is None


def test_irregular_positions_resolve_pitches_their_mean_step_would_alias():
    """ISO 230-2 places its targets at irregular intervals so that periodic errors are
    sampled: positions every 5 mm on average, each moved by up to a step, alias no
    period near 5 mm (uniform ones alias their step exactly), so the band searched
    reaches down to pitches the median step would have cut off."""
    uniform = np.arange(-100.0, 60.0 + 1e-9, 5.0)
    assert alias_pitch_mm(uniform, 0.4) == 5.0
    rng = np.random.default_rng(3)
    irregular = uniform + rng.uniform(0.0, 5.0, len(uniform))
    assert alias_pitch_mm(irregular, 0.4) < 2.0
    cov = AxisCoverage(0, len(irregular), -100.0, 65.0, 5.0, True, math.inf,
                       alias_mm=alias_pitch_mm(irregular, 0.4))
    assert cov.pitch_band_mm[0] < 5.0 < 2.5 * 5.0


def test_a_dense_scans_candidate_fits_cost_its_nodes_and_give_the_groups_sums():
    """The candidates' fits of a dense scan run in a few rows per pair of neighbouring
    nodes (``posenodes.NodeSpace``), not its thousands of groups, with the sums of
    squares the groups give (``GroupSpace.residuals``) to the rounding."""
    obs, _ = campaign(1, scan={"scan_step_mm": 0.1, "cycles": 1})
    problem = Problem(obs)
    space = problem.group_space
    assert space is not None and space._nodes is not None
    start = fit(obs, BASE_MODEL, method="exact", weighting="gls").theta
    nodes = space.node_space(start)
    assert nodes is not None
    assert len(nodes.rows.data) <= 2 * len(space._nodes.nodes) < len(space) / 2
    rng = np.random.default_rng(1)
    batch = np.repeat(start[None], 6, axis=0)
    for name, size in CHANGES.items():
        batch[:, PARAM_INDEX[name]] += rng.normal(0, size, len(batch))
    space.start_at(start)
    on_groups = np.sum(space.residuals(batch) ** 2, axis=1) + space.constant_rss
    on_rows = np.sum(nodes.residuals(batch) ** 2, axis=1) + nodes.constant
    assert np.allclose(on_rows, on_groups, rtol=1e-9, atol=0)
    assert np.sum(nodes.start**2) + nodes.constant == pytest.approx(
        np.sum(space.start_at(start) ** 2) + space.constant_rss, rel=1e-12)
    # a fit there is the fit on the groups
    extras = [("squareness.xy",), ("backlash.z", "leg_length.y")]
    fits = fit_many(problem, start, BASE_MODEL, extras)
    exact = [fit(obs, BASE_MODEL + e, method="exact", weighting="gls", theta0=fits.theta[k])
             for k, e in enumerate(extras)]
    assert np.allclose(fits.rss, [e.rss for e in exact], rtol=1e-6, atol=0)


def test_a_dense_scans_spline_knots_are_weighed_on_its_positions_and_chosen_exactly(
        monkeypatch):
    """The smooth map's knot counts are weighed on the positions' binned sums and only
    those near the best again on every group: the choice is the one every count
    weighed exactly makes, at a few exact weighings instead of eleven."""
    obs, _ = campaign(2, scan={"scan_step_mm": 0.1, "cycles": 1},
                      screw_map={1: ScrewMap((0.004, -0.003, 0.002))})
    problem = Problem(obs)
    start = fit(obs, BASE_MODEL, method="exact", weighting="gls")
    space = MapSpace(problem, start.theta, BASE_MODEL, start.rss)
    log_n = math.log(problem.n_data)
    exact_weighings = []
    weigh = MapSpace.gain_of
    monkeypatch.setattr(MapSpace, "gain_of",
                        lambda self, term: exact_weighings.append(term) or weigh(self, term))
    for cov in coverage(obs.layout, space.history.travel_mm):
        exact_weighings.clear()
        families = _Families(space, cov, BASE_MODEL, problem.noise)
        (grid,) = FAMILIES["screw_map"].search(families.searched(0.0))
        exact_weighings.clear()
        found = families.best(grid)
        every = [replace(found.term, shape={**found.term.shape, "knots": k})
                 for k in KNOTS if k + 4 <= cov.positions // 2]
        assert len(exact_weighings) < len(every) / 2
        bics = [-float(g.gain[0]) / problem.noise.variance + int(g.rank[0]) * log_n
                for g in (weigh(space, t) for t in every)]
        assert found.term == every[int(np.argmin(bics))]
        assert found.gain == pytest.approx(float(weigh(space, found.term).gain[0]), rel=1e-12)


def test_a_dense_scans_jacobian_is_its_nodes_interpolated_a_drifts_scaled_by_each_time():
    """Every reading's derivatives of a dense scan come from its nodes (a derivative
    is a change per unit, interpolated as the predictions' changes are), to a few
    1e-5 of each column's largest; a drift's, a time factor of the pose's, at each
    reading's own time. A 1 mm scan, a theta with drift: evaluated at every reading."""
    obs, _ = campaign(1, scan={"scan_step_mm": 0.1, "cycles": 2})
    problem = Problem(obs)
    start = fit(obs, BASE_MODEL, method="exact", weighting="gls").theta
    names = BASE_MODEL + EFFECT_PARAMETERS
    free = np.array([PARAM_INDEX[n] for n in names])
    at_nodes = problem.group_space.reading_jacobian(start, free)
    exact = obs.jacobian(start[None], free)[0]
    largest = np.abs(exact).max(axis=0)
    assert np.all(np.abs(at_nodes - exact) <= 1e-4 * largest + 1e-15)
    drift = [k for k, n in enumerate(names) if n.startswith("thermal_drift")]
    late = obs.layout.t_s > obs.layout.t_s.max() / 2
    assert np.all(np.abs(at_nodes[late][:, drift] - exact[late][:, drift])
                  <= 1e-4 * largest[drift])
    assert np.array_equal(problem.jacobian(start, names, weighted=False), at_nodes)
    drifting = start.copy()
    drifting[PARAM_INDEX["thermal_drift.x"]] = 0.001
    assert np.array_equal(problem.jacobian(drifting, names, weighted=False),
                          obs.jacobian(drifting[None], free)[0])
    coarse, _ = campaign(1)
    assert Problem(coarse).group_space.reading_jacobian(start, free) is None


def test_the_periodograms_grid_is_its_trial_functions_by_products_of_one_step():
    """The grid's sines and cosines are each next frequency's phases as products of one
    step's (a complex product, not a sine and a cosine per position and frequency):
    the trial functions to within roundings, over a chunk of the grid on a dense
    scan's positions."""
    q = np.arange(-100.0, 210.0, 0.0269)
    span = float(np.ptp(q))
    df = 1.0 / (5 * span)
    freqs = np.arange(1.0 / 103.0, 1.0 + df / 2, df)[:64]
    assert np.allclose(_grid_functions(freqs, q), _trial_functions(freqs, q),
                       rtol=0, atol=1e-11)
    assert np.allclose(_grid_functions(freqs[:1], q), _trial_functions(freqs[:1], q),
                       rtol=0, atol=1e-14)
