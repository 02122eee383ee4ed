"""The F test's second number said for what it is (issue 38.8): "F(11, 17897)" for 72
readings read as a misprint. Where the display's rounding, known, makes up most of a
posture mean's noise, that number is the noise's effective degrees of freedom
(Satterthwaite), not a count: the verdict says so, and what the repeats gave."""

from __future__ import annotations

import re

from ogacq.identify.consistency import fit_verdict
from ogacq.identify.fit import fit
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import PARAM_SETS, vector
from ogacq.sim.readings import simulated_readings
from ogacq.sim.truth import SimTruth
from tests.diagnose.campaigns import OFFSETS, layout


def _verdict(step_mm: float, scatter_mm: float, seed: int):
    machine = MachineSpec(310.25, -100.0, 60.0, gauge_resolution_mm=step_mm)
    obs = simulated_readings(machine, layout(machine=machine), SimTruth(vector(OFFSETS)),
                             scatter_mm=scatter_mm, step_mm=step_mm, seed=seed)
    return fit_verdict(fit(obs, PARAM_SETS["offsets"], method="exact", weighting="gls"))


def test_an_effective_denominator_is_named_with_the_repeats_share():
    """10 µm dial gauges scattering 1.6 µm (the papers' kind): the repeats give 52
    degrees of freedom, the rounding they share is known: F's denominator is 147."""
    verdict = _verdict(0.01, 0.0029, seed=1)
    assert verdict.noise.dof == 52 and verdict.noise_dof is not None
    shown = f"{verdict.noise_dof:.0f}"
    assert int(shown) > 2 * 52  # the case that read as a misprint
    text = verdict.describe()
    assert f"F(11, {shown}) = " in text
    assert (f"({shown}: the noise's effective degrees of freedom, 52 from the repeats' "
            "scatter and the rest from the display's rounding, which is known; "
            "Satterthwaite)") in text


def test_a_denominator_that_counts_the_repeats_needs_no_words():
    """1 µm gauges scattering 2 µm: the repeats measure the noise, F(11, 52) as before
    (the golden record's text is unchanged)."""
    text = _verdict(0.001, 0.002, seed=1).describe()
    assert re.search(r"F\(11, 52\) = [\d.]+, overall p", text), text
