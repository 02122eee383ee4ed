"""The batched fits of candidate models agree with the identification engine's own
exact fit, and the capability table agrees with its identifiability."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from ogacq.diagnose.batchfit import Design, Problem, fit_many
from ogacq.diagnose.gaugesums import GaugeSums
from ogacq.diagnose.library import BASE_MODEL, EFFECT_PARAMETERS, pairs, singles
from ogacq.diagnose.visibility import capability
from ogacq.identify.fit import fit
from ogacq.identify.identifiability import assess
from ogacq.identify.observations import readings_observations
from tests.diagnose.campaigns import NOISE_MM, layout, simulate


@pytest.fixture(scope="module")
def campaign():
    obs = simulate({"squareness.xy": 0.4, "thermal_drift.y": 0.2}, 11)
    base = fit(obs, BASE_MODEL, weighting="gls")
    return obs, Problem(obs), base


def test_library_is_every_effect_alone_and_in_pairs():
    assert len(singles()) == 27 and len(pairs()) == 351
    assert all(not n.startswith("joint_offset") for n in EFFECT_PARAMETERS)


def test_batched_fits_match_the_exact_fit(campaign):
    obs, problem, base = campaign
    extras = [("squareness.xy",), ("thermal_drift.y",), ("squareness.xy", "thermal_drift.y"),
              ("gauge_scale.z_x", "backlash.y")]
    batch = fit_many(problem, base.theta, BASE_MODEL, extras)
    for k, extra in enumerate(extras):
        exact = fit(obs, BASE_MODEL + extra, weighting="gls", theta0=batch.theta[k])
        assert batch.rss[k] == pytest.approx(exact.rss, rel=1e-6)
        assert np.allclose(batch.values(k), exact.values[3:], atol=0.02 * exact.std[3:])
    assert batch.full_rank().all()
    best = int(np.argmin(batch.rss))
    assert batch.extras[best] == ("squareness.xy", "thermal_drift.y")


def test_capability_std_is_the_identification_std(campaign):
    _, problem, base = campaign
    names = BASE_MODEL + EFFECT_PARAMETERS
    cap = capability(problem.jacobian(base.theta, names), names, NOISE_MM, problem.n_data)
    jw = problem.jacobian(base.theta, BASE_MODEL + ("backlash.z",))
    _, cov = assess(jw, None, BASE_MODEL + ("backlash.z",), NOISE_MM)
    assert cap.visibility["backlash.z"].std == pytest.approx(np.sqrt(cov[-1, -1]))
    assert cap.dof_after_offsets == 63 and cap.effect_rank == 14
    assert cap.invisible() == []


def test_drift_needs_time_and_backlash_needs_reversals():
    """A campaign read all at one instant cannot see drift; one whose drives never
    reverse cannot see lost motion. The capability says so."""
    lay = layout(seconds_per_posture=0.0)
    obs = simulate({}, 12, lay=lay)
    problem = Problem(obs)
    names = BASE_MODEL + EFFECT_PARAMETERS
    theta = fit(obs, BASE_MODEL).theta
    cap = capability(problem.jacobian(theta, names), names, NOISE_MM, problem.n_data)
    assert {n for n in cap.invisible()} == {"thermal_drift.x", "thermal_drift.y",
                                            "thermal_drift.z"}
    one_way = layout(("zero", "max"), cycles=1)
    problem = Problem(simulate({}, 13, lay=one_way))
    theta = fit(problem.obs, BASE_MODEL).theta
    cap = capability(problem.jacobian(theta, names), names, NOISE_MM, problem.n_data)
    assert {"backlash.x", "backlash.y", "backlash.z"} & set(cap.invisible() + cap.weak()) \
        or cap.saturated


def test_diagnosis_weighting_is_the_fit_weighting(campaign):
    """The diagnosis weights raw readings by per-gauge sums (no threaded matrix
    products); it must be the identification's weighting exactly, also when a gauge
    has lost all its readings (the robustness test drops a cell)."""
    obs, problem, base = campaign
    rng = np.random.default_rng(3)
    x = rng.normal(0.0, 0.01, (2, len(obs)))
    assert np.allclose(problem.weighted(x), problem.weighting.residual(x), rtol=0, atol=1e-14)
    assert np.allclose(problem.remove_zeros(x), obs.remove_zeros(x), rtol=0, atol=1e-14)
    names = BASE_MODEL + ("squareness.xy", "thermal_drift.y")
    raw = problem.jacobian(base.theta, names, weighted=False)
    assert np.allclose(problem.jacobian(base.theta, names), problem.weighting.jac(raw[None])[0],
                       rtol=0, atol=1e-12)
    rest = _no_reading_of_gauge_0(obs)
    sums = GaugeSums(rest, Problem(rest).weighting)
    y = x[:, obs.layout.gauge != 0]
    expected = np.stack([np.bincount(rest.layout.gauge, weights=row,
                                     minlength=rest.layout.n_gauges) for row in y])
    assert np.allclose(sums.sums(y), expected, rtol=0, atol=1e-14)
    assert np.all(np.isfinite(sums.weighted(y)))


def test_group_jacobian_is_the_readings_jacobian_on_group_means(campaign):
    obs, problem, base = campaign
    names = BASE_MODEL + ("squareness.xy", "backlash.z", "gauge_scale.x_y")
    space = problem.group_space
    readings = problem.jacobian(base.theta, names)  # (m, p), weighted
    groups = problem.weighting.groups
    first = np.sort(np.unique(groups.group, return_index=True)[1])  # a reading per group
    on_means = groups.group_space(readings.T).T[groups.group[first]]
    direct = space.jacobian_at(base.theta, names)
    assert direct.shape == (len(space), len(names))
    assert np.allclose(direct, on_means,
                       rtol=0, atol=1e-9 * np.abs(direct).max())


def test_capability_from_the_r_factor_is_the_capability_from_the_jacobian(campaign):
    _, problem, base = campaign
    names = BASE_MODEL + EFFECT_PARAMETERS
    design = Design(names, problem.jacobian(base.theta, names))
    full = capability(design.jw, names, NOISE_MM, problem.n_data)
    reduced = capability(design.factors[1], names, NOISE_MM, problem.n_data)
    assert reduced.effect_rank == full.effect_rank
    assert reduced.alias_groups() == full.alias_groups()
    for name, seen in full.visibility.items():
        other = reduced.visibility[name]
        assert other.std == pytest.approx(seen.std, rel=1e-9)
        assert other.absorbed == pytest.approx(seen.absorbed, rel=1e-9, abs=1e-12)
        assert [a for a, _ in other.aliases] == [a for a, _ in seen.aliases]


def _no_reading_of_gauge_0(obs):
    """The readings without gauge 0's, the gauge still in the layout (its key and
    setting) with no reading left: the edge GaugeSums must take."""
    keep = obs.layout.gauge != 0
    lay = obs.layout
    layout = replace(lay, q_mm=lay.q_mm[keep], leg=lay.leg[keep],
                     gauge_axis=lay.gauge_axis[keep], t_s=lay.t_s[keep],
                     cycle=lay.cycle[keep], tcp_mm=lay.tcp_mm[keep],
                     approach=lay.approach[keep], gauge=lay.gauge[keep],
                     posture=None if lay.posture is None else lay.posture[keep],
                     side=None if lay.side is None else lay.side[keep])
    return readings_observations(obs.machine, layout, obs.values[keep], obs.source)
