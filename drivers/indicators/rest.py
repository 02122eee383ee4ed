"""When a gauge's values show the machine at rest after a move: the stable settle.

Physics. After a move the machine rings in its modes: a gauge sees a damped
oscillation ``A exp(-t / tau) sin(2 pi f t + phi)`` on top of what it measures,
with its own noise and the rounding of its display (step ``q``). What matters is
the ringing left in the *reading*: under a third of the gauge's standard
uncertainty ``u`` from its noise and its display step, where it adds under
(1/3)^2 / 2 = 6 % to the reading's variance (a sinusoid of amplitude ``a`` at a
random phase has variance a^2 / 2). ``u`` is judged by what the gauge shows, not
by a tolerance: a 10 um dial, a 1 um and a 0.1 um indicator each get their own.

The rule, per gauge:

1. Rest reference. Where the machine is known still, the gauge's scatter is its
   rest: its first settle of a run waits the whole bound (as a fixed settle does),
   and the sample standard deviation of its values over the second half of that
   wait is ``s_rest`` (at least :data:`REST_VALUES` values, else no reference and
   every settle of that gauge ends at the bound). ``u^2 = max(s_rest^2, q^2 / 12)``:
   a gauge quieter than its display step shows a still value yet rounds either
   way, by q / sqrt(12) (JCGM 100:2008 F.2.2.1).
2. Two windows at rest. The values of the last two windows, each spanning at
   least ``window_s`` (from a value to one at least ``window_s`` later) and
   holding at least :data:`MIN_VALUES` values, each have a sample variance
   consistent with ``u``: ``s^2 <= u^2 chi2_{n-1}(0.99) / (n - 1)``, the one-sided
   chi-square test of a standard deviation (NIST/SEMATECH e-Handbook of
   Statistical Methods, 1.3.5.8). A window spans a whole period of any ringing
   of ``f >= 1 / window_s`` (the lowest frequency covered; a user sets it with
   ``settle_window_s = 1 / f_lowest``), so a crest, where consecutive values
   agree, never passes for rest: its trough is in the same window. Over a whole
   period a ringing adds A^2 / 2 to the window's variance: a window of 5 values
   or more that passes, even with its noise at its 1 % low, hides an amplitude of
   at most about 2.4 u (at the 1 % level a window at rest is taken for moving
   once in a hundred, which costs a value's time, not a reading).
3. The reading is the mean of both windows' values: over at least two periods
   of any ``f >= 1 / window_s`` the mean of a sinusoid is at most
   ``|sin(pi x) / (pi x)|`` <= 0.128 of its amplitude (x = span f >= 2; the
   largest side lobe past 2 is at x = 2.46), so the ringing left in the reading
   is at most 0.128 x 2.4 u = 0.31 u, under u / 3, at the worst frequency and
   the worst noise at once (typically a tenth of u: a sinusoid sampled evenly over
   whole periods cancels). The ringing decays meanwhile, which only lowers it;
   the bound does not rely on the decay.
4. The bound: a gauge whose windows never look like rest (a ringing that does
   not decay, a drift, a rounding flicker wider than its rest showed) ends at
   ``bound_s`` and is then read afresh, exactly as after a fixed wait.

What no rule that reads the gauge can see: a ringing faster than half the rate
the gauge is read at (an 01A exchange every 15.6 ms at 9600 baud: 32 Hz) is
sampled at aliased phases; its variance still shows, but one at a multiple of
the reading rate would look still. Choose ``settle = "fixed"`` for such a machine.
No source for the rule as a whole: the project's, from the physics above.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

from ogacq_drivers.indicators.base import Reading, StableReading

# A window's variance means little on fewer values (and 3 samples can all miss a
# sinusoid's crests): no source, the project's floor. A multiplexer's gauges, read in
# turn, get fewer values per window: give them a longer window.
MIN_VALUES = 5
# Values the rest reference needs (7 degrees of freedom: s^2 within a factor of
# about 2 of the variance, 90 % of the time); no source.
REST_VALUES = 8
LEVEL = 0.01  # the chi-square test's level: rest judged "moving" 1 % of the time
_Z_UPPER = 2.3263478740408408  # the standard normal's 0.99 quantile
_EPS_MM2 = 1e-12  # quantised values: float noise in a variance is not scatter


def variance_limit(dof: int) -> float:
    """chi2_dof(0.99) / dof: how far above the variance it tests a sample variance of
    ``dof`` degrees of freedom may lie at the 1 % level (Wilson and Hilferty's
    approximation of the chi-square quantile, Proc. Natl. Acad. Sci. 17 (1931) 684,
    within 1 % of the tables from 3 degrees of freedom)."""
    k = 2.0 / (9.0 * dof)
    return (1.0 - k + _Z_UPPER * math.sqrt(k)) ** 3


def sample_variance(values: list[float]) -> float:
    mean = sum(values) / len(values)
    return sum((v - mean) ** 2 for v in values) / (len(values) - 1)


@dataclass(frozen=True, slots=True)
class RestReference:
    """What a gauge showed at rest: its scatter, and the uncertainty a window is judged
    against (``u_mm``, its display step's q / sqrt(12) at the least)."""

    scatter_mm: float
    u_mm: float
    values: int


def rest_reference(values: list[float], display_step_mm: float) -> RestReference | None:
    """The reference from values read at rest; None on too few of them."""
    if len(values) < REST_VALUES:
        return None
    scatter = math.sqrt(sample_variance(values))
    return RestReference(scatter, math.sqrt(max(scatter**2, display_step_mm**2 / 12)), len(values))


class RestJudge:
    """One gauge's settle: values in, the reading out once two windows look like rest
    (the rule in the module's docstring). ``t`` are seconds since the settle began,
    on the clock that also bounds it."""

    def __init__(self, window_s: float, display_step_mm: float,
                 reference: RestReference | None) -> None:
        self.window_s, self.display_step_mm = window_s, display_step_mm
        self.reference = reference
        self.values: deque[tuple[float, Reading]] = deque()
        self.count = 0

    def clear(self) -> None:
        """A garbled frame or a busy gauge breaks the run of values."""
        self.values.clear()

    def add(self, t: float, reading: Reading) -> StableReading | None:
        """The reading once the gauge is at rest, else None."""
        self.count += 1
        self.values.append((t, reading))
        if self.reference is None:  # measuring the rest: keep every value for the tail
            return None
        windows = self._windows()
        if windows is None:
            return None
        first, second = windows
        limit = self.reference.u_mm**2
        for window in windows:
            mm = [r.value_mm for _, r in window]
            if sample_variance(mm) > limit * variance_limit(len(mm) - 1) + _EPS_MM2:
                return None
        both = [r for _, r in first + second]
        mm = [r.value_mm for r in both]
        return StableReading(value_mm=sum(mm) / len(mm), spread_mm=max(mm) - min(mm),
                             readings=tuple(both))

    def last_values(self) -> StableReading | None:
        """The mean of the last two windows' values (at least ``2 * MIN_VALUES`` of the
        last), not judged: what a gauge reads that was not at rest by the bound, the
        machine then as still as after a fixed wait; None before any value."""
        if not self.values:
            return None
        end = self.values[-1][0]
        recent = [r for t, r in self.values if t >= end - 2 * self.window_s]
        if len(recent) < 2 * MIN_VALUES:
            recent = [r for _, r in list(self.values)[-2 * MIN_VALUES:]]
        mm = [r.value_mm for r in recent]
        return StableReading(value_mm=sum(mm) / len(mm), spread_mm=max(mm) - min(mm),
                             readings=tuple(recent))

    def rest_from_tail(self, since_s: float) -> RestReference | None:
        """The rest reference from the values read from ``since_s`` on (the second half
        of a settle that waited the whole bound)."""
        return rest_reference([r.value_mm for t, r in self.values if t >= since_s],
                              self.display_step_mm)

    def _windows(self) -> tuple[list[tuple[float, Reading]], list[tuple[float, Reading]]] | None:
        """The last two windows (each from a value to the last one at least
        ``window_s`` before its end), with enough values each; None before that.
        Values before the older window are let go."""
        values, w = list(self.values), self.window_s
        start2 = _last_at_or_before(values, values[-1][0] - w)
        if start2 is None or start2 == 0:
            return None
        end1 = start2 - 1
        start1 = _last_at_or_before(values, values[end1][0] - w, upto=end1)
        if start1 is None:
            return None
        for _ in range(start1):
            self.values.popleft()
        first, second = values[start1:end1 + 1], values[start2:]
        if len(first) < MIN_VALUES or len(second) < MIN_VALUES:
            return None
        return first, second


def _last_at_or_before(values: list[tuple[float, Reading]], t: float,
                       upto: int | None = None) -> int | None:
    """Index of the last value read at or before ``t`` (among the first ``upto`` + 1)."""
    found = None
    for i, (ti, _) in enumerate(values[: None if upto is None else upto + 1]):
        if ti <= t:
            found = i
        else:
            break
    return found
