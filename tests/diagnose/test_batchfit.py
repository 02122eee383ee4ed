"""The batched fits of candidate models agree with the identification engine's own
exact fit, and the capability table agrees with its identifiability."""

from __future__ import annotations

import numpy as np
import pytest

from ogacq.diagnose.batchfit import Problem, fit_many
from ogacq.diagnose.library import BASE_MODEL, EFFECT_PARAMETERS, pairs, singles
from ogacq.diagnose.visibility import capability
from ogacq.identify.fit import fit
from ogacq.identify.identifiability import assess
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
