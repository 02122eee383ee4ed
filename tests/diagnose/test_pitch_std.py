"""A cyclic error's pitch std is what the readings' noise leaves, not its own signal.

Found: a 4 µm, 4.0 mm lead on z read by the designed scan (gauge noise 0.19 µm from
the repeats) was found 4.0012 ± 0.0126 mm: the std came from the variance the model
left *before* the cyclic term, the error's own signal, 14 times the noise's. Its map's
band reached 2.1 µm at the far end of the travel, "loose" beside the 4 µm
correction, and every such scan was read again (+555 reading steps). A std that grows
with the error it measures is the tell: by the curvature of the profile chi-square a
pitch's std falls as 1 / amplitude at a given noise (Cramér-Rao bound of a
sinusoid's frequency)."""

from __future__ import annotations

import tempfile
from pathlib import Path

import pytest

from ogacq.diagnose.diagnosis import diagnose
from ogacq.model.machine import PAPER_PROTOTYPE_DIGITAL as MACHINE
from ogacq.protocol.plan import ProtocolConfig, planned_layout
from ogacq.protocol.scan_design import design_scan, sampled_band
from ogacq.sim.readings import simulated_readings
from ogacq.sim.truth import random_truth, read_effects

NOISE_MM = 0.0009  # a reading's scatter: dithered by the 1 um display, so maps are searched


@pytest.fixture(scope="module")
def design():
    found = design_scan(MACHINE, ProtocolConfig(), noise_mm=0.0005)
    return planned_layout(found.protocol, MACHINE), sampled_band(found.protocol, MACHINE)


def pitch_found(design, amplitude_mm: float, seed: int) -> tuple[float, float]:
    layout, band = design
    folder = Path(tempfile.mkdtemp())
    (folder / "e.toml").write_text(f"[joint_offset]\nx = 0.4\ny = -0.3\n[lead_screw.z]\n"
                                   f"amplitude_mm = {amplitude_mm}\npitch_mm = 4.0\n")
    truth = read_effects(folder / "e.toml", random_truth(1))
    obs = simulated_readings(MACHINE, layout, truth, scatter_mm=NOISE_MM, step_mm=0.0001,
                             seed=seed)
    (step,) = diagnose(obs, pitch_band_mm=band).mapped.search.steps
    assert step.added.term.name == "lead_screw_cyclic.z"
    return step.added.term.shape["pitch_mm"], step.added.shape_std


def test_a_pitch_std_falls_with_the_amplitude_and_covers_its_error(design):
    small = pitch_found(design, 0.004, seed=5)
    large = pitch_found(design, 0.016, seed=5)
    # four times the amplitude at the same noise: a quarter of the std (before: alike,
    # 0.0185 and 0.0130 mm, each scaled by the signal it measures)
    assert large[1] == pytest.approx(small[1] / 4, rel=0.35), (small, large)
    for pitch, std in (small, large):
        assert abs(pitch - 4.0) < 4 * std, (pitch, std)
