"""The noise of a reading that is the mean of several gauge values, beside the scatter
its repeats show.

A settled reading is the mean of several values, their count recorded
(``averaged``); the machine file states one value's noise (sigma) behind the display
step s. Were the n values independent, a reading's variance would be

    (sigma^2 + s^2/12 - c) / n + c,   c = c(sigma, s) (``noise.shared_rounding_variance``)

(the undithered rounding never averages away). That is a floor: consecutive values
are correlated (a drift, a display slower than it is read), and the mean of
correlated values varies more (JCGM 100:2008 4.2.7), so the truth lies between the
floor and one value's noise, and only repeats show where. Hence
(``noise._estimate_noise``): with repeats that can test the stated noise, their
scatter is set beside the floor (the repeats' noise used when the stated one is
above it beyond chance); without repeats, the stated noise is kept and the floor
said beside it. Judged against the floor, fits of correlated values would be called
inconsistent on an assumption: issue 37 measured settles of 6-32 values whose
consistent fits showed chi2/dof 0.06-0.31 against the value's noise and 1 to 5
against the floor at 16 values. No source beyond that measurement and GUM 4.2.7."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ogacq.identify.distributions import chi2_sf
from ogacq.model.units import UM_PER_MM


@dataclass(frozen=True)
class AveragedReadings:
    """What the settle's counts say of the noise of a reading, beside its repeats."""

    values: int  # the median count of gauge values a reading is the mean of
    fewest: int
    most: int
    per_value_mm: float  # the machine file's noise of one value
    floor_mm: float  # a reading's noise were its values independent
    repeats_mm: float | None = None  # a reading's scatter about its repeats' mean
    # one-sided p of the repeats' scatter below, and above, the floor's (None: the
    # repeats cannot test it: none, identical, or the rounding not dithered)
    below_p: float | None = None
    above_p: float | None = None
    level: float = 0.01

    def describe(self) -> str:
        """``stated 0.5 µm per value, 16 values a reading → ≥ 0.13 µm; repeats show ...``"""
        spread = f" ({self.fewest}-{self.most})" if self.fewest != self.most else ""
        text = (f"stated {_um(self.per_value_mm)} µm per value, {self.values} values a "
                f"reading{spread} → ≥ {_um(self.floor_mm)} µm (were they independent)")
        if self.repeats_mm is None:
            return (text + "; no repeats show where between that and the value's "
                    f"{_um(self.per_value_mm)} µm: judged against the value's")
        text += f"; repeats show {_um(self.repeats_mm)} µm"
        if self.below_p is not None and self.below_p < self.level:
            return (text + f", below even that beyond chance ({tail_p(self.below_p)}): the "
                    "gauges scatter less than the machine file states")
        if self.above_p is not None and self.above_p < self.level:
            return (text + f", above it beyond chance ({tail_p(self.above_p)}): a reading's "
                    "values are not independent")
        if self.below_p is None:
            return text
        return text + ", as independent values would"


def averaged_readings(counts: np.ndarray | None, per_value_mm: float, within_var: float,
                      shared_var: float, pure: tuple[float, int] | None, *, testable: bool,
                      level: float) -> AveragedReadings | None:
    """The floor of readings that average ``counts`` values each (0: not recorded),
    one value scattering ``per_value_mm`` with ``within_var`` about its repeats' mean
    and ``shared_var`` repeated with them (noise.py's ``within_variance`` and
    ``shared_rounding_variance``); ``pure``: the repeats' sum of squares about their
    means and its dof, tested against the floor where ``testable``. None where no
    reading recorded a count above one (nothing was averaged that ogacq knows of)."""
    known = np.asarray(counts)[np.asarray(counts) > 0] if counts is not None else None
    if known is None or not len(known) or int(known.max()) <= 1:
        return None
    # a pool of readings of several counts scatters with the mean of 1/n
    within_floor = within_var * float(np.mean(1.0 / known))
    floor = math.sqrt(within_floor + shared_var)
    repeats = below = above = None
    if pure is not None:
        ss, dof = pure
        repeats = math.sqrt(ss / dof)
        if testable and within_floor > 0:
            # ss / within_floor is chi-square with dof under the floor (the test of a
            # variance, NIST/SEMATECH e-Handbook 1.3.5.8), one tail each way
            above = float(chi2_sf(dof, ss / within_floor))
            below = 1.0 - above
    return AveragedReadings(int(np.median(known)), int(known.min()), int(known.max()),
                            per_value_mm, floor, repeats, below, above, level)


def _um(mm: float) -> str:
    return f"{mm * UM_PER_MM:.2g}"


def tail_p(p: float) -> str:
    """``p = 0.0031``; below what 1 - p of the other tail resolves, ``p < 1e-15``."""
    return "p < 1e-15" if p < 1e-15 else f"p = {p:.2g}"
