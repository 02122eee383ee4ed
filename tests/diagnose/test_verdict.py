"""The verdict's statistics: which noise, which test, which p."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from ogacq.diagnose.diagnosis import diagnose
from ogacq.diagnose.verdict import NoiseBasis, judge, nested_test, noise_basis
from ogacq.identify.observations import deviations_observations, readings_observations
from ogacq.model.machine import PAPER_PROTOTYPE
from tests.diagnose.campaigns import (
    MACHINE,
    MACHINE_WITHOUT_NOISE,
    NOISE_MM,
    RICH,
    STEP_MM,
    layout,
    simulate,
)


def test_stated_noise_carries_the_display_rounding():
    noise = noise_basis(simulate({}, 1))
    assert noise.source == "machine file" and not noise.measured
    assert noise.sigma_mm == pytest.approx(math.hypot(NOISE_MM, STEP_MM / math.sqrt(12)))


def test_noise_from_repeats_uses_pure_error_and_the_lack_of_fit_test():
    obs = simulate({}, 2, machine=MACHINE_WITHOUT_NOISE)
    noise = noise_basis(obs)
    assert noise.source == "repeated readings"
    assert noise.dof == 52  # 72 readings in 20 groups of gauge, posture and approach
    assert 0.0015 < noise.sigma_mm < 0.0028
    verdict = judge(noise.pure_error_ss + 11 * noise.variance * 2.0, 63, 0.002, noise)
    assert verdict.test == "lack-of-fit F"
    assert verdict.statistic == pytest.approx(2.0)
    assert verdict.overall_p == pytest.approx(stats.f.sf(2.0, 11, 52))


def test_tabulated_deviations_are_judged_against_the_display_step():
    obs = deviations_observations(PAPER_PROTOTYPE, [("dx_y", 0.1), ("dy_x", 0.2)])
    noise = noise_basis(obs)
    assert noise.source == "gauge resolution" and noise.sigma_mm == 0.01


def test_chi_square_verdict():
    noise = NoiseBasis(0.002, "machine file")
    v = judge(63 * 0.002**2 * 1.5, 63, 0.0024, noise)
    assert v.test == "chi-square" and v.chi2_dof == pytest.approx(1.5)
    assert v.p_value == pytest.approx(stats.chi2.sf(94.5, 63))
    assert not v.consistent
    assert judge(63 * 0.002**2, 63, 0.002, noise).consistent


def test_nested_test_credits_only_what_beats_the_remaining_misfit():
    noise = NoiseBasis(0.001, "machine file")
    s2 = noise.variance
    # bigger model within the noise: likelihood-ratio test against the noise
    f_stat, p = nested_test(100 * s2, 60 * s2, 1, 60, noise)
    assert f_stat == pytest.approx(40) and p == pytest.approx(stats.chi2.sf(40, 1))
    # bigger model still far from the noise: judged against what it leaves
    f_stat, p = nested_test(600 * s2, 500 * s2, 1, 50, noise)
    assert f_stat == pytest.approx(10) and p == pytest.approx(stats.f.sf(10, 1, 50))


def test_cell_test_sees_a_local_disturbance_better_than_the_overall_test():
    """10 um on the three readings of one gauge at one posture is diluted in the
    overall chi-square of a 162-reading campaign, but plain in its cell."""
    lay = layout(RICH)
    obs = simulate({}, 3, lay=lay)
    cell = (lay.gauge_axis == 2) & (lay.leg == 1) & (lay.tcp_mm[:, 1] < -99.0)
    shifted = readings_observations(MACHINE, lay, obs.values + np.where(cell, 0.010, 0.0))
    d = diagnose(shifted)
    assert d.base.worst_cell.cell == "z_y at min"
    assert d.base.worst_cell.p_value < 1e-6 < d.base.overall_p
    assert not d.base.consistent
