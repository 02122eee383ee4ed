"""Machines unlike the prototype (a small one, a large one, an asymmetric travel) and
protocols unlike the papers' (one cycle, a missing leg): the simulator's readings
against the independent model of ``reference_model.py`` (its own geometry, its leg
length set to the machine's), and the joint offsets identified within their stated
uncertainty. ``bench/bench_unseen.py`` sweeps many such cases over many seeds."""

from __future__ import annotations

import numpy as np
import pytest

from ogacq.diagnose.diagnosis import diagnose
from ogacq.identify.fit import fit
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import PARAM_SETS
from ogacq.protocol.plan import ProtocolConfig, planned_layout
from ogacq.sim.readings import simulated_readings
from tests.diagnose import reference_model as ref
from tests.diagnose.campaigns import assert_axis_errors_match_reference

OFFSETS = (1.5, -3.0, 4.0)
SMALL = MachineSpec(120.0, -30.0, 20.0, gauge_resolution_mm=0.001,
                    gauge_repeatability_mm=0.002)
LARGE = MachineSpec(900.0, -300.0, 250.0, gauge_resolution_mm=0.001,
                    gauge_repeatability_mm=0.002)
ASYMMETRIC = MachineSpec(310.25, -160.0, 20.0, gauge_resolution_mm=0.001,
                         gauge_repeatability_mm=0.002)
MACHINES = {"small": SMALL, "large": LARGE, "asymmetric": ASYMMETRIC}


def _offsets_truth() -> dict[str, float]:
    return {f"joint_offset.{a}": v for a, v in zip("xyz", OFFSETS, strict=True)}


@pytest.mark.parametrize("name", MACHINES)
def test_readings_on_another_geometry_are_the_independent_models(
        name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """Offsets of a few mm, a cyclic screw error, a screw map, a bowed rail and a
    hysteresis on a scan of the whole travel: the same readings to 1e-8 mm."""
    machine = MACHINES[name]
    monkeypatch.setattr(ref, "L", machine.leg_length_mm)
    lo, hi = machine.rho_min_mm, machine.rho_max_mm
    lay = planned_layout(ProtocolConfig(scan_step_mm=(hi - lo) / 20, cycles=2), machine)
    theirs = assert_axis_errors_match_reference(machine, lay, OFFSETS)
    assert np.ptp(theirs) > 1.0  # offsets of mm on these postures move the readings


@pytest.mark.parametrize("name", MACHINES)
def test_joint_offsets_of_another_geometry_are_found_within_their_std(name: str) -> None:
    """Readings of the simulator (the test above holds it to the independent model), one
    cycle of the papers' postures, fitted by
    ogacq: each offset within 4 std of the truth (a 6e-5 chance per offset), the std
    that of 2 um gauges (not absurd: between 0.1 and 100 um), and nothing named."""
    machine = MACHINES[name]
    lay = planned_layout(ProtocolConfig(cycles=1), machine)
    obs = simulated_readings(machine, lay, _offsets_truth(), scatter_mm=0.002,
                             step_mm=0.001, seed=11)
    result = fit(obs, PARAM_SETS["offsets"])
    assert result.converged
    assert np.all((result.std > 1e-4) & (result.std < 0.1)), result.std
    assert np.all(np.abs(result.values - np.array(OFFSETS)) < 4 * result.std)
    assert diagnose(obs).effects == []
