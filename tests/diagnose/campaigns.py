"""Seeded simulated campaigns for the diagnosis tests: the exact model with chosen
effects, each gauge's arbitrary zero, Gaussian gauge noise and display rounding."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from ogacq.identify.fit import fit
from ogacq.identify.observations import Observations, readings_observations
from ogacq.model.machine import MachineSpec
from ogacq.model.measurement import ReadingsLayout
from ogacq.model.parameters import PARAM_SETS, vector
from ogacq.protocol.plan import ProtocolConfig, planned_layout

NOISE_MM = 0.002
STEP_MM = 0.001
MACHINE = MachineSpec(310.25, -100.0, 60.0, gauge_resolution_mm=STEP_MM,
                      gauge_repeatability_mm=NOISE_MM)
MACHINE_WITHOUT_NOISE = MachineSpec(310.25, -100.0, 60.0, gauge_resolution_mm=STEP_MM)
# Encoder zero errors of the size the papers found (mm): they also give the gauges
# readings to scale, without which a gauge gain error shows nowhere.
OFFSETS = {"joint_offset.x": 2.0, "joint_offset.y": 2.0, "joint_offset.z": -2.0}
PAPERS = ("zero", "max", "min", "zero")
# Intermediate postures, each approached from both sides.
RICH = ("zero", 30.0, "max", 30.0, "zero", -50.0, "min", -50.0, "zero")


def layout(postures: Sequence[str | float] = PAPERS, machine: MachineSpec = MACHINE, *,
           seconds_per_posture: float = 20.0, **kw) -> ReadingsLayout:
    return planned_layout(ProtocolConfig(postures=tuple(postures), **kw), machine,
                          seconds_per_posture=seconds_per_posture)


def simulate(effects: Mapping[str, float], seed: int, *, machine: MachineSpec = MACHINE,
             lay: ReadingsLayout | None = None, lead_screw: tuple[float, float] | None = None,
             offsets: Mapping[str, float] = OFFSETS) -> Observations:
    """Readings of a campaign on a machine with ``effects`` (beside ``offsets``).
    ``lead_screw`` (amplitude, pitch mm): every joint is really at
    ``q + A sin(2 pi q / pitch)`` while the readings record the commanded ``q``."""
    lay = lay if lay is not None else layout(machine=machine)
    truth_layout = lay
    if lead_screw is not None:
        amplitude, pitch = lead_screw
        q = lay.q_mm + amplitude * np.sin(2 * np.pi * lay.q_mm / pitch)
        truth_layout = ReadingsLayout.build(q, lay.leg, lay.gauge_axis, lay.t_s, lay.cycle,
                                            lay.tcp_mm, lay.approach)
    rng = np.random.default_rng(seed)
    truth = {**offsets, **effects}
    clean = readings_observations(machine, truth_layout, np.zeros(len(lay))).predict(
        vector(truth))
    zeros = rng.uniform(2.0, 10.0, lay.n_gauges)
    values = clean + zeros[lay.gauge] + rng.normal(0.0, NOISE_MM, len(lay))
    return readings_observations(machine, lay, np.round(values / STEP_MM) * STEP_MM)


def raw_signature_rms(effects: Mapping[str, float], machine: MachineSpec = MACHINE,
                      lay: ReadingsLayout | None = None) -> float:
    """What the effects alone do to the readings (gauge zeros removed), rms mm."""
    lay = lay if lay is not None else layout(machine=machine)
    obs = readings_observations(machine, lay, np.zeros(len(lay)))
    with_effects = obs.predict(vector({**OFFSETS, **effects}))
    without = obs.predict(vector(OFFSETS))
    return float(np.sqrt(np.mean(obs.remove_zeros(with_effects - without) ** 2)))


def offsets_residual_rms(effects: Mapping[str, float], machine: MachineSpec = MACHINE,
                         lay: ReadingsLayout | None = None) -> float:
    """What the offsets-only fit leaves of the effects' noise-free readings, rms mm."""
    lay = lay if lay is not None else layout(machine=machine)
    clean = readings_observations(machine, lay, np.zeros(len(lay))).predict(
        vector({**OFFSETS, **effects}))
    fitted = fit(readings_observations(machine, lay, clean), PARAM_SETS["offsets"])
    return fitted.residual_rms_mm


def assert_axis_errors_match_reference(machine: MachineSpec, lay: ReadingsLayout,
                                       offsets: tuple[float, float, float]) -> np.ndarray:
    """The simulator's exact readings with the joint ``offsets``, a cyclic screw error
    on x, a screw map on y, z's rail bowed toward x and a hysteresis on y, against the
    independent geometry of ``reference_model`` (its leg length must be the
    machine's): the same to 1e-8 mm, each gauge's zero aside. Returns the reference's
    readings, for the caller to check the errors show."""
    from ogacq.sim.physics import true_coordinates
    from ogacq.sim.truth import Hysteresis, LeadScrewError, RailBow, ScrewMap, SimTruth
    from tests.diagnose import reference_model as ref

    truth = SimTruth(vector({f"joint_offset.{a}": v for a, v in zip("xyz", offsets,
                                                                    strict=True)}),
                     lead_screw={0: LeadScrewError(0.005, 5.0, 30.0)},
                     screw_map={1: ScrewMap((0.0, 0.01, 0.02))},
                     rail_bow={2: RailBow("x", 0.01)}, hysteresis={1: Hysteresis(0.02, 6.0)})
    physics = ref.Physics(offsets=offsets, cyclic={0: (0.005, 5.0, 30.0)},
                          polynomial={1: (0.0, 0.01, 0.02)},
                          bow={2: (0, 0.01, machine.rho_min_mm, machine.rho_max_mm)},
                          hysteresis={1: (0.02, 6.0)})
    ours = true_coordinates(truth, lay, machine)
    theirs = ref.readings(lay.q_mm, lay.leg, lay.gauge_axis, physics)
    gauge = ref.gauge_index(lay.leg, lay.gauge_axis)
    diff = ours - theirs
    diff -= (np.bincount(gauge, weights=diff) / np.bincount(gauge))[gauge]
    assert np.max(np.abs(diff)) < 1e-8
    return theirs
