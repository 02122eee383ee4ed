"""When a campaign has recovered a hidden parameter: the one bound the end-to-end tests
share.

A campaign through the real drivers settles, reads and paces in real time, so its
readings differ from run to run; its estimate lies within z std of the truth. A
bound of 3 std fails a correct campaign 0.27 % of the time per parameter, and with
three axes in each of a dozen campaign tests the suite would fail about one run in
ten for nothing. The bound is set instead so that a correct campaign fails a test
once in a million runs, all the parameters it compares taken together (Bonferroni):
5.10 std for three offsets, 4.89 for one. A campaign that misses by more is wrong,
not unlucky.
"""

from __future__ import annotations

from scipy.stats import norm

FALSE_FAILURE = 1e-6  # a correct campaign's chance to fail one test


def bound_in_std(compared: int) -> float:
    """The two-sided normal quantile for FALSE_FAILURE shared by ``compared`` checks."""
    return float(norm.isf(FALSE_FAILURE / (2 * compared)))


def recovered(got: float, truth: float, std: float, compared: int = 3) -> bool:
    """``got`` is ``truth`` within the noise of a campaign that compares ``compared``
    parameters."""
    return abs(got - truth) < bound_in_std(compared) * std
