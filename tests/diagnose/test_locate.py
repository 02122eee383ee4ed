"""Locating the misfit: shares per gauge, leg, posture and cycle against what noise
alone would give; trends with time; differences between approach sides."""

from __future__ import annotations

import numpy as np
import pytest

from ogacq.diagnose.batchfit import Problem
from ogacq.diagnose.diagnosis import diagnose
from ogacq.diagnose.locate import _approach_differences, residual_variance, row_labels
from tests.diagnose.campaigns import RICH, layout, simulate


def test_shares_add_up_and_match_noise_alone_on_average():
    shares = []
    for seed in range(40):
        d = diagnose(simulate({}, 300 + seed))
        for level in ("gauge", "leg", "posture", "cycle"):
            assert abs(sum(g.share for g in d.located.level(level)) - 1.0) < 1e-9
        shares.append([(g.share, g.expected_share) for g in d.located.level("posture")])
    # under noise alone each posture carries its expected share on average
    by_key = np.array([[s for s, _ in sorted(row, key=lambda t: t[1])] for row in shares])
    expected = np.array([[e for _, e in sorted(row, key=lambda t: t[1])] for row in shares])
    assert np.allclose(by_key.mean(axis=0), expected.mean(axis=0), atol=0.05)


def test_expected_residual_variance_sums_to_the_dof():
    d = diagnose(simulate({}, 1))
    obs = d.base_fit.observations
    jac = Problem(obs).jacobian(d.base_fit.theta, d.base_fit.names, weighted=False)
    assert abs(np.sum(residual_variance(obs, jac)) - d.base.dof) < 1e-6


def test_thermal_drift_shows_as_a_trend_with_time():
    d = diagnose(simulate({"thermal_drift.y": 0.4}, 2))
    trends = [t for t in d.located.trends if t.p_value < 0.01]
    assert trends, [(t.gauge, t.slope_mm_per_h, t.p_value) for t in d.located.trends]
    # and none remains once the drift is modelled
    assert not [t for t in d.remaining.trends if t.p_value < 0.001]


def test_backlash_shows_between_approach_sides():
    """Intermediate postures read from both sides: lost motion of the drive shows as a
    difference between the two sides at the same posture."""
    d = diagnose(simulate({"backlash.x": 0.02}, 3, lay=layout(RICH)))
    diffs = [a for a in d.located.approach if a.p_value < 0.01]
    # the x drive's lost motion moves the TCP along x: the y and z legs tilt along x
    assert {a.gauge for a in diffs} <= {"x_y", "x_z"} and diffs
    assert "backlash.x" in [e.name for e in d.effects]


def test_papers_protocol_reads_no_posture_from_both_sides_except_the_first():
    d = diagnose(simulate({}, 4))
    assert all(a.posture == "zero" for a in d.located.approach)


def test_located_json_is_sorted_gauge_shares():
    d = diagnose(simulate({"gauge_scale.z_x": 40000.0}, 5))
    located = d.to_json()["located"]
    assert [set(g) for g in located] == [{"leg", "gauge_axis", "share"}] * 6
    shares = [g["share"] for g in located]
    assert shares == sorted(shares, reverse=True)
    assert abs(sum(shares) - 1.0) < 1e-3


def approach_differences_by_loop(labels, residuals, sigma_mm):
    """The former cell-by-cell definition, kept as the reference."""
    out = []
    gauges = labels.gauge
    for g in dict.fromkeys(gauges.tolist()):
        for posture in dict.fromkeys(labels.posture[gauges == g].tolist()):
            sel = (gauges == g) & (labels.posture == posture)
            sides, counts = np.unique(labels.approach[sel], return_counts=True)
            if len(sides) < 2 or "" in sides:
                continue
            first, second = sides[np.argsort(-counts, kind="stable")[:2]]
            a = residuals[sel & (labels.approach == first)]
            b = residuals[sel & (labels.approach == second)]
            std = sigma_mm * np.sqrt(1 / len(a) + 1 / len(b))
            out.append((g, posture, (str(first), str(second)), a.mean() - b.mean(), std))
    return out


@pytest.mark.parametrize("postures", [RICH, ("zero", "max", "min", "zero")])
def test_approach_differences_are_the_cell_by_cell_loop(postures):
    obs = simulate({"backlash.x": 0.02}, 3, lay=layout(postures, approach="sequence"))
    labels = row_labels(obs)
    residuals = np.random.default_rng(0).normal(0, 0.002, len(obs))
    ours = [(a.gauge, a.posture, a.sides, a.difference_mm, a.std_mm)
            for a in _approach_differences(labels, residuals, 0.002)]
    theirs = approach_differences_by_loop(labels, residuals, 0.002)
    assert [o[:3] for o in ours] == [t[:3] for t in theirs] and ours
    assert np.allclose([o[3:] for o in ours], [t[3:] for t in theirs], rtol=0, atol=1e-15)
