"""The nonlinear fit recovers known parameters within its own reported std."""

import numpy as np

from ogacq.identify.fit import fit
from ogacq.identify.observations import readings_observations
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import PARAM_SETS, vector
from ogacq.protocol.plan import ProtocolConfig, planned_layout

MACHINE = MachineSpec(310.25, -100.0, 60.0, gauge_resolution_mm=0.0001,
                      gauge_repeatability_mm=0.002)


def simulate(truth, seed, noise=0.002):
    layout = planned_layout(ProtocolConfig(), MACHINE)
    rng = np.random.default_rng(seed)
    zeros = rng.uniform(2, 10, layout.n_gauges)  # each gauge's arbitrary zero
    clean = readings_observations(MACHINE, layout, np.zeros(len(layout))).predict(
        vector(truth))
    values = clean + zeros[layout.gauge] + rng.normal(0, noise, len(layout))
    return readings_observations(MACHINE, layout, values)


def test_large_offsets_recovered_exactly_without_noise():
    truth = {"joint_offset.x": 3.0, "joint_offset.y": -2.5, "joint_offset.z": 1.7}
    obs = simulate(truth, 0, noise=0.0)
    r = fit(obs, PARAM_SETS["offsets"])
    assert r.converged
    assert np.allclose(r.values, list(truth.values()), atol=1e-7)
    # the linearised equations are off by the second-order terms at this size
    lin = fit(obs, PARAM_SETS["offsets"], method="linear")
    assert np.max(np.abs(lin.values - list(truth.values()))) > 1e-3


def test_offsets_coverage_over_many_seeds():
    rng = np.random.default_rng(2026)
    z = []
    for seed in range(300):
        truth = dict(zip(PARAM_SETS["offsets"], rng.uniform(-2, 2, 3), strict=True))
        r = fit(simulate(truth, seed), PARAM_SETS["offsets"])
        assert r.converged
        z.extend((r.values - list(truth.values())) / r.std)
    z = np.array(z)
    inside = np.mean(np.abs(z) < 2.0)
    assert 0.93 < inside < 0.975, inside  # 95.4 % expected; binomial sd 0.6 %
    assert 0.85 < np.mean(z**2) < 1.15


def test_offsets_and_lengths_from_readings_coverage():
    """The six together are ill-conditioned but still covered by their std."""
    rng = np.random.default_rng(7)
    z = []
    for seed in range(150):
        truth = dict(zip(PARAM_SETS["both"], rng.uniform(-1, 1, 6), strict=True))
        r = fit(simulate(truth, 1000 + seed), PARAM_SETS["both"])
        z.extend((r.values - list(truth.values())) / r.std)
    z = np.array(z)
    assert 0.92 < np.mean(np.abs(z) < 2.0) < 0.98


def test_noise_from_repeats_when_the_machine_file_has_none():
    machine = MachineSpec(310.25, -100.0, 60.0, gauge_resolution_mm=0.0001)
    layout = planned_layout(ProtocolConfig(), machine)
    rng = np.random.default_rng(5)
    clean = readings_observations(machine, layout, np.zeros(len(layout))).predict(
        vector({"joint_offset.x": 0.4}))
    obs = readings_observations(machine, layout, clean + rng.normal(0, 0.003, len(layout)))
    r = fit(obs, PARAM_SETS["offsets"])
    assert r.noise.source == "repeated readings"
    assert 0.002 < r.noise.sigma_mm < 0.004


def test_parameters_that_act_only_on_a_tilted_leg_are_still_fitted():
    """At the nominal start gauge position has no effect (every leg is parallel); the
    fit must not leave it there once the offsets have tilted the legs."""
    truth = {"joint_offset.x": 2.0, "joint_offset.y": 2.0, "joint_offset.z": -2.0,
             "gauge_position.x": 0.56}
    obs = simulate(truth, 3, noise=0.0)
    names = (*PARAM_SETS["offsets"], "gauge_position.x")
    r = fit(obs, names)
    assert r.converged
    assert np.allclose(r.values, list(truth.values()), atol=1e-6)
    assert r.identifiability.rank == 4 and np.all(np.isfinite(r.std)) and np.all(r.std > 0)


def test_coverage_when_the_display_step_dominates_the_noise():
    """10 um dials with 1 um noise: repeats read the same, the rounding error repeats
    every cycle, and the std must say so (it does not shrink with the cycles)."""
    machine = MachineSpec(310.25, -100.0, 60.0, gauge_resolution_mm=0.01)
    layout = planned_layout(ProtocolConfig(), machine)
    rng = np.random.default_rng(99)
    z = []
    for _ in range(200):
        truth = dict(zip(PARAM_SETS["offsets"], rng.uniform(-2, 2, 3), strict=True))
        clean = readings_observations(machine, layout, np.zeros(len(layout))).predict(
            vector(truth))
        noisy = clean + rng.uniform(2, 10, 6)[layout.gauge] + rng.normal(0, 0.001, len(clean))
        values = np.round(noisy / 0.01) * 0.01
        r = fit(readings_observations(machine, layout, values), PARAM_SETS["offsets"])
        assert r.noise.step_mm == 0.01 and r.noise.shared_var > 0
        z.extend((r.values - list(truth.values())) / r.std)
    z = np.array(z)
    inside = np.mean(np.abs(z) < 2.0)
    # a uniform rounding error is no Gaussian, but its std must not be understated
    assert inside > 0.93, inside
    assert np.mean(z**2) < 1.2
