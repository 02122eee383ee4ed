"""A validation is "worse" on its misfit only when the misfit grew beyond chance
(``validate.misfit_grew``): a fit as good as the calibration's, not within the noise
by chance, restored a machine put right."""

from __future__ import annotations

from ogacq.calibration.validate import misfit_grew
from ogacq.identify.consistency import Verdict
from ogacq.identify.noise import GaugeNoise

NOISE = GaugeNoise.stated(0.0005, 0.001)


def verdict(chi2_dof: float, dof: int, state: str = "inconsistent") -> Verdict:
    return Verdict(state=state, test="chi-square", statistic=chi2_dof * dof, dof=dof,
                   noise_dof=None, overall_p=0.5, p_value=0.005, level=0.01,
                   rss=0.0, rms_mm=0.0, noise=NOISE)


def test_a_misfit_a_little_larger_by_chance_is_no_growth():
    # both near 1 per dof: the ratio 1.1 is well within F(60, 60)'s spread
    assert not misfit_grew(verdict(1.0, 60, "consistent"), verdict(1.1, 60))


def test_a_misfit_grown_beyond_chance_is_growth():
    # a correction that made it worse: 3 per dof against 1 on 60 dof each
    assert misfit_grew(verdict(1.0, 60, "consistent"), verdict(3.0, 60))
    # and where the calibration campaign was itself far from the noise, the validation
    # must grow beyond its ratio too
    assert not misfit_grew(verdict(5.0, 60), verdict(5.5, 60))
    assert misfit_grew(verdict(5.0, 60), verdict(15.0, 60))
