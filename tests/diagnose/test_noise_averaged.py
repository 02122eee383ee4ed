"""The noise of a reading that averages several gauge values (issue 37.7): the floor
its count gives a stated per-value noise, set beside the scatter its repeats show,
and which of them the verdict is judged against."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ogacq.identify.consistency import fit_verdict
from ogacq.identify.fit import fit
from ogacq.identify.noise import (
    noise_for,
    shared_rounding_variance,
    within_variance,
)
from ogacq.identify.noise_averaged import averaged_readings
from ogacq.identify.observations import Observations, readings_observations
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import PARAM_SETS, vector
from tests.diagnose.campaigns import MACHINE, NOISE_MM, OFFSETS, STEP_MM, layout

VALUES = 16  # the median a stable settle averaged on the independent machine


def averaged_campaign(seed: int, *, values: int = VALUES, correlated: bool = False,
                      machine: MachineSpec = MACHINE, postures=("zero", "max", "min", "zero"),
                      cycles: int = 3, counts: bool = True, noise_mm: float = NOISE_MM,
                      ) -> Observations:
    """A campaign whose every reading is the mean of ``values`` displayed values of a
    gauge scattering ``noise_mm`` per value: independent values, or ``correlated`` (one
    value shown ``values`` times: a display that updates once per settle)."""
    lay = layout(postures, machine=machine, cycles=cycles)
    clean = readings_observations(machine, lay, np.zeros(len(lay))).predict(vector(OFFSETS))
    rng = np.random.default_rng(seed)
    true = clean + rng.uniform(2.0, 10.0, lay.n_gauges)[lay.gauge]
    noise = rng.normal(0.0, noise_mm, (len(lay), 1 if correlated else values))
    shown = np.round((true[:, None] + noise) / STEP_MM) * STEP_MM
    every = np.broadcast_to(shown, (len(lay), values))
    spread = every.std(axis=1, ddof=1) if values > 1 else np.full(len(lay), np.nan)
    return readings_observations(machine, lay, every.mean(axis=1), "averaged",
                                 np.full(len(lay), values) if counts else None,
                                 spread if counts else None)


@pytest.mark.parametrize(("sigma", "step"), [(0.0005, 0.001), (0.0002, 0.01), (0.003, 0.01)])
def test_the_floor_is_the_noise_of_a_mean_of_independent_rounded_values(sigma, step):
    """Brute force, not the series: a mean of 16 independent values rounded to the
    display, over a uniform rounding phase; a gauge far quieter than its step keeps
    the step's s / sqrt(12) however many values (the 10 um dial's 0.2 um gauge)."""
    rng = np.random.default_rng(1)
    x = rng.uniform(0.0, step, 100_000)
    values = np.round((x[:, None] + rng.normal(0.0, sigma, (x.size, VALUES))) / step) * step
    error = values.mean(axis=1) - x
    found = averaged_readings(np.full(10, VALUES), sigma, within_variance(sigma, step),
                              shared_rounding_variance(sigma, step), None, testable=False,
                              level=0.01)
    assert found is not None and found.values == VALUES
    assert found.floor_mm == pytest.approx(float(np.std(error)), rel=0.02)
    if sigma < step / 10:  # the rounding does not average away: no lower for more values
        assert found.floor_mm > 0.9 * step / math.sqrt(12)
        more = averaged_readings(np.full(10, 1000), sigma, within_variance(sigma, step),
                                 shared_rounding_variance(sigma, step), None,
                                 testable=False, level=0.01)
        assert more is not None and more.floor_mm == pytest.approx(found.floor_mm, rel=0.05)
    else:
        assert found.floor_mm < math.hypot(sigma, step / math.sqrt(12)) / 3


def test_readings_of_independent_values_show_the_floor_and_the_repeats_noise_is_used():
    """The issue's case: the machine file's per-value noise, readings that average 16
    values. The repeats show a quarter of it, as the floor says: the verdict is judged
    against the repeats' noise, and the noise line sets the two side by side."""
    obs = averaged_campaign(2)
    noise = noise_for(obs)
    assert noise.measured and noise.refuted_mm == NOISE_MM
    assert noise.sigma_mm < NOISE_MM / 2
    averaged = noise.averaged
    assert averaged is not None and averaged.values == VALUES
    floor = math.sqrt(within_variance(NOISE_MM, STEP_MM) / VALUES
                      + shared_rounding_variance(NOISE_MM, STEP_MM))
    assert averaged.floor_mm == pytest.approx(floor)
    assert averaged.repeats_mm is not None and \
        averaged.repeats_mm == pytest.approx(floor, rel=0.3)
    text = noise.describe()
    assert "stated 2 µm per value, 16 values a reading → ≥ 0.51 µm" in text, text
    assert "as independent values would" in text, text
    assert fit_verdict(fit(obs, PARAM_SETS["offsets"])).consistent


def test_the_noise_measured_from_averaged_readings_is_a_means_not_a_rounded_values():
    """The issue's case: 0.5 µm a value on a 1 µm display, 16 values a reading. The
    repeats scatter 0.14 µm; inverted as one rounded value's, that was a gauge far
    quieter than its step whose whole 0.29 µm rounding repeats, so a true model's F
    per dof was 0.07-0.23. The values' own scatter within each reading shows the
    rounding dithered: the noise is the readings' 0.14 µm and the F about 1."""
    quiet = MachineSpec(310.25, -100.0, 60.0, gauge_resolution_mm=STEP_MM,
                        gauge_repeatability_mm=0.0005)
    f_per_dof = []
    for seed in range(6):
        obs = averaged_campaign(seed, machine=quiet, noise_mm=0.0005)
        noise = noise_for(obs)
        assert noise.measured and noise.sigma_mm == pytest.approx(0.00014, rel=0.25)
        assert noise.dithered and not noise.rounding_dominated
        assert noise.scatter_mm == pytest.approx(0.0005, rel=0.1)  # a value's, within readings
        f_per_dof.append(fit_verdict(fit(obs, PARAM_SETS["offsets"])).chi2_dof)
    assert 0.5 < float(np.mean(f_per_dof)) < 2.0, f_per_dof
    # a display that updates once per settle: its readings' values show no scatter, so
    # the whole rounding is taken to repeat, as for readings of one value
    one = noise_for(averaged_campaign(1, machine=quiet, noise_mm=0.0005, correlated=True))
    assert one.sigma_mm >= STEP_MM / math.sqrt(12)


def test_a_reading_whose_values_are_one_keeps_the_stated_noise_and_says_why():
    """A display that updates once per settle: 16 values that are one. The repeats
    scatter as one value does, far above the floor: the values are not independent,
    and the stated noise, which the repeats do not refute, is the verdict's."""
    noise = noise_for(averaged_campaign(3, correlated=True))
    assert noise.source == "machine file" and noise.scatter_mm == NOISE_MM
    assert noise.averaged is not None and noise.averaged.above_p is not None
    assert noise.averaged.above_p < 1e-6
    assert "a reading's values are not independent" in noise.describe()


def test_without_repeats_the_stated_value_noise_is_kept_and_the_floor_said():
    """One pass, each posture read once: nothing shows where between the floor and
    the value's noise a reading lies, so the fit is not judged against the floor on
    an assumption of independence."""
    obs = averaged_campaign(4, postures=("zero", "max", "min"), cycles=1)
    noise = noise_for(obs)
    assert noise.source == "machine file"
    assert noise.sigma_mm == pytest.approx(math.hypot(NOISE_MM, STEP_MM / math.sqrt(12)))
    assert noise.averaged is not None and noise.averaged.repeats_mm is None
    assert "no repeats show where between that and the value's 2 µm" in noise.describe()


def test_readings_without_counts_or_of_one_value_say_nothing_of_averaging():
    """A readings CSV, a session written before the count was recorded, values typed
    by eye: the noise is what it was."""
    assert noise_for(averaged_campaign(2, counts=False)).averaged is None
    assert noise_for(averaged_campaign(2, values=1)).averaged is None


def test_the_counts_follow_the_readings_a_fit_keeps():
    obs = averaged_campaign(5)
    obs.averaged[::2] = 8
    keep = np.arange(len(obs)) % 3 != 0
    kept = obs.kept(keep)
    assert kept.averaged is not None and list(kept.averaged) == list(obs.averaged[keep])
