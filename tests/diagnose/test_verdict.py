"""The verdict's statistics: which noise, which test, which p."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from ogacq.diagnose.diagnosis import diagnose
from ogacq.diagnose.nested import bic_change, nested_test
from ogacq.identify.consistency import LEVEL, fit_verdict
from ogacq.identify.fit import fit
from ogacq.identify.noise import (
    STATED_NOISE_LEVEL,
    GaugeNoise,
    identical_pair_probability,
    identical_repeats_scatter,
    noise_for,
    pure_error,
    shared_rounding_variance,
    sigma_from_scatter,
    stated_noise_p,
    within_variance,
)
from ogacq.identify.observations import deviations_observations, readings_observations
from ogacq.model.machine import PAPER_PROTOTYPE, MachineSpec
from ogacq.model.parameters import PARAM_SETS, vector
from ogacq.protocol.plan import ProtocolConfig, planned_layout
from ogacq.sim.readings import simulated_readings
from tests.diagnose.campaigns import (
    MACHINE,
    MACHINE_WITHOUT_NOISE,
    NOISE_MM,
    OFFSETS,
    RICH,
    STEP_MM,
    layout,
    simulate,
)


def test_stated_noise_carries_the_display_rounding():
    noise = noise_for(simulate({}, 1))
    assert noise.source == "machine file" and not noise.measured
    assert noise.sigma_mm == pytest.approx(math.hypot(NOISE_MM, STEP_MM / math.sqrt(12)))


def test_noise_from_repeats_uses_pure_error_and_the_lack_of_fit_test():
    obs = simulate({}, 2, machine=MACHINE_WITHOUT_NOISE)
    noise = noise_for(obs)
    assert noise.source == "repeated readings"
    assert noise.dof == 52  # 72 readings in 20 groups of gauge, posture and approach
    assert 0.0015 < noise.sigma_mm < 0.0028
    verdict = fit_verdict(fit(obs, PARAM_SETS["offsets"]))
    assert verdict.test == "lack-of-fit F" and verdict.dof == 20 - 6 - 3
    # 2 um scatter on a 1 um display: rounding is independent, the F has the pure
    # error's 52 dof
    assert verdict.noise_dof == pytest.approx(52, rel=0.02)
    assert verdict.overall_p == pytest.approx(
        stats.f.sf(verdict.statistic, verdict.dof, verdict.noise_dof))


def test_a_stated_noise_the_repeats_refute_is_said_and_the_measured_one_used():
    """The machine file states 8 um where the gauges scatter 2 um (a reading that
    averages 16 values carries a quarter of a value's noise): the repeats' scatter
    refutes it (two-sided chi-square at the verdict's level), the verdict is judged
    against the repeats' noise and says why; the stated 2 um is kept."""
    stated_4x = MachineSpec(310.25, -100.0, 60.0, gauge_resolution_mm=STEP_MM,
                            gauge_repeatability_mm=4 * NOISE_MM)
    assert STATED_NOISE_LEVEL == LEVEL
    noise = noise_for(simulate({}, 2, machine=stated_4x))
    assert noise.measured and noise.refuted_mm == 4 * NOISE_MM
    assert noise.refuted_p is not None and noise.refuted_p < LEVEL
    assert 0.0015 < noise.sigma_mm < 0.0028
    assert "the machine file's 8 µm scatter disagrees with the repeats'" in noise.describe()
    d = diagnose(simulate({}, 2, machine=stated_4x))
    assert d.noise.measured and "disagrees" in d.noise.describe()
    kept = noise_for(simulate({}, 2))
    assert kept.source == "machine file" and kept.refuted_mm is None
    p = stated_noise_p(NOISE_MM, STEP_MM, *pure_error(simulate({}, 2)))
    assert p is not None and p > LEVEL


def test_tabulated_deviations_are_judged_against_the_display_step_said_to_be_assumed():
    obs = deviations_observations(PAPER_PROTOTYPE, [("dx_y", 0.1), ("dy_x", 0.2)])
    noise = noise_for(obs)
    assert noise.source == "gauge resolution" and noise.sigma_mm == 0.01 and noise.assumed


def test_shared_rounding_matches_a_direct_simulation():
    """c(sigma, s): the covariance of two repeats' errors, over a uniform rounding
    phase, computed here by brute force and not by the series."""
    rng = np.random.default_rng(0)
    step = 0.01
    for sigma in (0.0005, 0.001, 0.002, 0.003):
        x = rng.uniform(0, step, 400_000)
        e1 = np.round((x + rng.normal(0, sigma, x.size)) / step) * step - x
        e2 = np.round((x + rng.normal(0, sigma, x.size)) / step) * step - x
        assert np.cov(e1, e2)[0, 1] == pytest.approx(
            shared_rounding_variance(sigma, step), abs=2e-8 + 0.03 * step**2 / 12)
        assert np.var(e1) == pytest.approx(sigma**2 + step**2 / 12, rel=0.02)
    assert shared_rounding_variance(0.0, step) == pytest.approx(step**2 / 12, rel=1e-3)
    assert shared_rounding_variance(step, step) < 1e-12


def test_scatter_of_repeats_is_inverted_to_the_gauge_scatter():
    for sigma in (0.0, 0.0003, 0.001, 0.004, 0.02):
        assert sigma_from_scatter(within_variance(sigma, 0.01), 0.01) == pytest.approx(
            sigma, abs=1e-9)


def test_dial_far_coarser_than_the_noise_is_not_a_false_alarm():
    """The issue's case: 10 um dials, 1 um noise measured from repeats. The cycles
    round alike, so an F-test against their scatter alone (the old rule) read about
    3 under noise alone; the posture means are judged against the rounding."""
    machine = MachineSpec(310.25, -100.0, 60.0, gauge_resolution_mm=0.01)
    lay = layout(machine=machine)
    rng = np.random.default_rng(5)
    clean = readings_observations(machine, lay, np.zeros(len(lay))).predict(
        _offsets_vector())
    values = clean + rng.uniform(2, 10, lay.n_gauges)[lay.gauge] + rng.normal(0, 0.001,
                                                                               len(lay))
    obs = readings_observations(machine, lay, np.round(values / 0.01) * 0.01)
    noise = noise_for(obs)
    assert noise.rounding_dominated
    verdict = fit_verdict(fit(obs, PARAM_SETS["offsets"]))
    assert verdict.consistent, verdict.describe()
    assert any("display step dominates" in n for n in verdict.notes)


def _offsets_vector():
    return vector({"joint_offset.x": 0.8, "joint_offset.y": -0.5, "joint_offset.z": 1.2})


def test_identical_repeats_bound_the_scatter_they_are_judged_against():
    """Repeats that all read identically show the scatter small, not zero: it is taken
    as the largest under which so many groups read identically 1 time in 100."""
    machine = MachineSpec(310.25, -100.0, 60.0, gauge_resolution_mm=0.01)
    lay = layout(machine=machine)
    clean = readings_observations(machine, lay, np.zeros(len(lay))).predict(_offsets_vector())
    values = np.round((clean + 3.0) / 0.01) * 0.01  # no scatter at all
    verdict = fit_verdict(fit(readings_observations(machine, lay, values),
                              PARAM_SETS["offsets"]))
    groups = int(np.count_nonzero(lay.repeat_size > 1))
    assert verdict.noise.scatter_mm == pytest.approx(identical_repeats_scatter(groups, 0.01))
    assert 0 < verdict.noise.scatter_mm < 0.01 and verdict.test == "lack-of-fit F"
    assert verdict.consistent
    assert any("read identically" in n for n in verdict.notes)


def test_identical_repeats_credit_no_mean_with_less_variance_than_any_scatter_gives():
    """Whatever the scatter up to the bound, a mean of n repeats varies no more than
    the noise of identical repeats says: a larger scatter alone would dither the
    rounding and credit a mean of three with less (5 % false alarms with a 10 um
    display on a 0.3 um gauge)."""
    machine = MachineSpec(310.25, -100.0, 60.0, gauge_resolution_mm=0.01)
    lay = layout(machine=machine)
    clean = readings_observations(machine, lay, np.zeros(len(lay))).predict(_offsets_vector())
    noise = noise_for(readings_observations(machine, lay, np.round((clean + 3) / 0.01) * 0.01))
    bound = noise.scatter_mm
    for n in range(1, 7):
        credited = noise.within_var / n + noise.shared_var
        for sigma in np.linspace(0.0, bound, 21):
            shared = shared_rounding_variance(float(sigma), 0.01)
            assert within_variance(float(sigma), 0.01) / n + shared <= credited * (1 + 1e-12)


def test_identical_pair_probability_is_that_of_rounded_readings():
    """The closed form against rounded normal pairs drawn at a uniform phase (2e5 each:
    a binomial std of 0.0011)."""
    rng = np.random.default_rng(0)
    for sigma in (0.1, 0.5, 1.0):
        phase = rng.uniform(0, 1, 200_000)
        a, b = phase + rng.normal(0, sigma, (2, 200_000))
        drawn = float(np.mean(np.round(a) == np.round(b)))
        assert identical_pair_probability(sigma, 1.0) == pytest.approx(drawn, abs=0.006)


def test_a_few_repeats_that_happen_to_agree_raise_no_false_alarm():
    """One cycle on two legs: two groups of repeats. A 2 um gauge on a 1 um display
    reads both pairs identically in 7 campaigns of 300; the fit was then judged
    against the rounding alone (0.29 um) and 6 of the 7 were 'NOT within the gauge
    noise' at p down to 1e-116, and diagnosed."""
    machine = MachineSpec(310.25, -100.0, 60.0, gauge_resolution_mm=0.001)
    lay = planned_layout(ProtocolConfig(legs=("x", "y"), cycles=1), machine)
    for seed in (1, 43, 47):
        obs = simulated_readings(machine, lay, OFFSETS, scatter_mm=0.002, step_mm=0.001,
                                 seed=seed)
        result = fit(obs, PARAM_SETS["offsets"])
        assert result.noise.pure_error_ss == 0.0  # the repeats agree
        assert fit_verdict(result).consistent, seed


def test_no_redundancy_cannot_be_judged():
    obs = deviations_observations(PAPER_PROTOTYPE, [("dx_y+", 0.1), ("dy_x+", 0.2),
                                                    ("dz_x+", 0.3)])
    verdict = fit_verdict(fit(obs, PARAM_SETS["offsets"], method="linear"))
    assert verdict.state == "undetermined" and not verdict.consistent
    assert "no redundancy" in verdict.describe()


def test_nested_test_credits_only_what_beats_the_remaining_misfit():
    noise = GaugeNoise(0.001, "machine file")
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


def test_information_criteria_change_is_schwarzs_difference():
    """The one BIC of the effect selection and the map search: the full
    criteria of the smaller and the bigger model, the noise known, differenced."""
    noise = GaugeNoise(0.002, "machine file", 0.001)
    n_data, rss_small, rss_big = 72, 1e-3, 7e-4

    def bic(rss: float, k: int) -> float:
        return rss / noise.variance + k * math.log(n_data)

    drop = rss_small - rss_big
    assert bic_change(drop, 2, n_data, noise) == pytest.approx(bic(rss_big, 7) - bic(rss_small, 5))
    # element-wise for candidates: a drop worth its parameters is negative, none positive
    many = bic_change(np.array([drop, 0.0]), np.array([1, 1]), n_data, noise)
    assert many[0] < 0 < many[1] == pytest.approx(math.log(n_data))
