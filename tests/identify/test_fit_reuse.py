"""What a fit computes once and reuses (issue 14: a refit's fixed cost) is computed
again when what it came from changes: the noise with the readings or the machine,
the repeat groups' whitener with the noise; and the SVD a fit takes is numpy's,
to the last bit, failing as numpy's does."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from ogacq.identify.fit import Weighting, fit
from ogacq.identify.identifiability import reduced_svd
from ogacq.identify.noise import GaugeNoise, group_whitener, noise_for
from ogacq.identify.observations import Observations, readings_observations
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import PARAM_SETS, vector
from ogacq.protocol.plan import ProtocolConfig, planned_layout

MACHINE = MachineSpec(310.25, -100.0, 60.0, gauge_resolution_mm=0.001)
OFFSETS = PARAM_SETS["offsets"]


def campaign(seed: int = 1) -> Observations:
    layout = planned_layout(ProtocolConfig(cycles=3), MACHINE)
    rng = np.random.default_rng(seed)
    clean = readings_observations(MACHINE, layout, np.zeros(len(layout))).predict(
        vector({"joint_offset.x": -0.49, "joint_offset.z": 1.2}))
    noisy = clean + rng.uniform(2, 10, layout.n_gauges)[layout.gauge] \
        + rng.normal(0, 0.002, len(layout))
    return readings_observations(MACHINE, layout, np.round(noisy, 3))


def test_noise_follows_readings_changed_in_place():
    obs = campaign()
    before = noise_for(obs)
    assert noise_for(obs) is before  # estimated once
    obs.values[::7] += 0.004  # the same array, edited
    after = noise_for(obs)
    assert after != before
    assert after == noise_for(Observations(obs.machine, obs.layout, obs.values.copy(),
                                           obs.labels))


def test_noise_follows_the_machine():
    obs = campaign()
    measured = noise_for(obs)
    obs.machine = replace(MACHINE, gauge_repeatability_mm=0.002)
    stated = noise_for(obs)
    assert measured.source == "repeated readings" and stated.source == "machine file"


def test_whitener_follows_the_noise():
    obs = campaign()
    first = group_whitener(obs, noise_for(obs))
    assert group_whitener(obs, noise_for(obs)) is first
    other = GaugeNoise.stated(0.0002, 0.001)  # the display step shared by the repeats
    second = group_whitener(obs, other)
    assert second is not first
    assert not np.array_equal(second.mean_scale, first.mean_scale)


def test_a_refit_after_an_edit_is_the_refit_of_the_edited_readings():
    obs = campaign()
    fit(obs, OFFSETS)
    obs.values[5] += 0.01
    edited = fit(obs, OFFSETS)
    fresh = fit(campaign(), OFFSETS)
    fresh_edited = campaign()
    fresh_edited.values[5] += 0.01
    assert np.array_equal(edited.values, fit(fresh_edited, OFFSETS).values)
    assert not np.array_equal(edited.values, fresh.values)


def test_residual_and_jacobian_weighted_together_are_weighted_apart():
    obs = campaign()
    w = Weighting(obs, "ols")
    rng = np.random.default_rng(2)
    r, jac = rng.normal(size=(1, len(obs))), rng.normal(size=(1, len(obs), 3))
    white, jw = w.residual_and_jac(r, jac)
    assert np.array_equal(white, w.residual(r)) and np.array_equal(jw, w.jac(jac))


def test_reduced_svd_is_numpys_and_fails_as_numpys():
    rng = np.random.default_rng(4)
    for shape in ((72, 3), (1, 72, 3), (5, 40, 6)):
        a = rng.normal(size=shape)
        for mine, numpys in zip(reduced_svd(a), np.linalg.svd(a, full_matrices=False),
                                strict=True):
            assert np.array_equal(mine, numpys)
    broken = rng.normal(size=(1, 10, 3))
    broken[0, 2, 1] = np.nan
    with pytest.raises(np.linalg.LinAlgError):
        reduced_svd(broken)
