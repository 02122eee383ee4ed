"""The side a joint approached from before its first recorded move: unknown, not
"none".

A readings CSV records where each joint was, not how it got there, so a reading
before a joint's first recorded move is taken at the middle of its lost motion
(side 0): with a backlash, such readings misfit by half of it, and a leg length can
fit better than the backlash that is there. The side is one nuisance unknown per
joint (a joint unmoved since power-on may be anywhere within its lost motion), so it
is resolved only where the lost motion decides it (``resolve_sides``); otherwise it
stays in the middle, half a backlash off where a wrong side would be a whole one. A
side is never taken merely as the less wrong of the two ends: a wind-up read
unhomed fits one end better than the other and the middle best (issue 37: it was
taken as from below and propped up by a leg length and a warm-up).

The recorded approach is left as it is (repeat groups, the joint offsets' verdict):
the model's side is the layout's ``side``. Sessions record neither their homing nor
the moves before their first reading, so they are treated alike."""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from ogacq.diagnose.batchfit import Problem, fit_many
from ogacq.diagnose.library import BASE_MODEL
from ogacq.identify.noise import GaugeNoise
from ogacq.identify.observations import Observations
from ogacq.model.gauges import AXES
from ogacq.model.joint_sensitivity import joint_sensitivity

# A reading whose sensitivity to its joint is below this is not moved by the side: a
# lost motion of tens of micrometres would change it by a fraction of one (at the Zero
# posture the sensitivity is of the order of the offsets over the leg, 1e-2 at most).
SENSITIVE = 0.02
# chi-square of one degree of freedom at 1 %: a side is taken only when the readings
# favour it that clearly (a wrong side misplaces the joint by a whole backlash, the
# unknown middle by half of one), and the backlash must be there as clearly
BETTER_BY = 6.63
SIGNIFICANT = 6.63


@dataclass(frozen=True)
class SideChoice:
    """The side taken for a joint's readings before its first recorded move."""

    axis: int
    side: int  # +1 from below, -1 from above, 0 still unknown
    readings: int  # how many readings it concerns
    gain_chi2: float  # by how much the better side fits better than the other

    def describe(self) -> str:
        name = AXES[self.axis]
        if self.side == 0:
            return (f"joint {name}: the side it was approached from before its first "
                    f"recorded move is unknown ({self.readings} readings); neither side fits "
                    "its lost motion clearly better than the other or than its middle")
        way = "below" if self.side > 0 else "above"
        return (f"joint {name}: the side before its first recorded move is unknown "
                f"({self.readings} readings); taken as from {way}, where its backlash fits "
                f"better by chi-square {self.gain_chi2:.1f} (and better than in its middle)")


def unknown_rows(obs: Observations) -> np.ndarray:
    """(n, 3) the readings whose joint's side is unknown (0) though the joint moves
    later in the record."""
    side = obs.layout.lost_motion_side
    later = np.flip(np.maximum.accumulate(np.flip(side != 0, axis=0), axis=0), axis=0)
    return (side == 0) & later


def resolve_sides(obs: Observations, noise: GaugeNoise, problem: Problem,
                  theta: np.ndarray) -> tuple[Observations, Problem, list[SideChoice]]:
    """``obs`` with each joint's unknown side resolved where its lost motion decides it
    (``theta``: the joint offsets' fit): every combination of sides fitted with the
    offsets and the three backlashes; a side taken from the best one when flipping it,
    or putting it in the middle, fits worse by ``BETTER_BY`` and its backlash is
    significant there."""
    if not obs.raw:
        return obs, problem, []
    unknown = unknown_rows(obs)
    if not unknown.any():
        return obs, problem, []
    along = joint_sensitivity(theta, obs.layout, obs.machine).along()[0]
    rows = unknown & (np.abs(along) > SENSITIVE)
    joints = [a for a in range(3) if rows[:, a].any()]
    if not joints:
        return obs, problem, []
    backlash = tuple(f"backlash.{a}" for a in AXES)
    side = obs.layout.lost_motion_side.copy()

    def trial(signs: tuple[int, ...]) -> np.ndarray:
        out = side.copy()
        for axis, sign in zip(joints, signs, strict=True):
            out[rows[:, axis], axis] = sign
        return out

    def misfit(signs: tuple[int, ...]) -> tuple[Problem, float]:
        variant = problem.with_side(trial(signs))
        return variant, float(fit_many(variant, theta, BASE_MODEL, [backlash]).rss[0])

    combos = list(itertools.product((1, -1), repeat=len(joints)))
    fits = {signs: misfit(signs) for signs in combos}
    best = min(combos, key=lambda c: fits[c][1])
    variant, rss = fits[best]
    # the lost motion the sides are tried with is a constant backlash: where it does
    # not fit within the noise (a wind-up, a cyclic error), every difference between
    # sides grows with its misfit; the bars grow with it (the fit's reduced
    # chi-square, Birge's ratio: R. T. Birge, Phys. Rev. 40, 207, 1932)
    spread = max(1.0, rss / noise.variance
                 / max(problem.n_data - len(BASE_MODEL) - len(backlash), 1))
    choices = []
    taken = list(best)
    for k, axis in enumerate(joints):
        flipped = tuple(-s if j == k else s for j, s in enumerate(best))
        gain = (fits[flipped][1] - rss) / noise.variance
        if gain > BETTER_BY * spread and _backlash_cost(variant, theta, backlash, axis, rss) \
                / noise.variance > SIGNIFICANT * spread and \
                (misfit(tuple(0 if j == k else s for j, s in enumerate(best)))[1] - rss) \
                / noise.variance > BETTER_BY * spread:
            choices.append(SideChoice(axis, best[k], int(rows[:, axis].sum()), gain))
        else:
            taken[k] = 0
            choices.append(SideChoice(axis, 0, int(rows[:, axis].sum()), gain))
    if not any(taken):
        return obs, problem, choices
    resolved = variant if taken == list(best) else problem.with_side(trial(tuple(taken)))
    return resolved.obs, resolved, choices


def _backlash_cost(variant: Problem, theta: np.ndarray, backlash: tuple[str, ...], axis: int,
                   rss: float) -> float:
    """By how much the weighted sum of squares ``rss`` of the joint offsets and the
    three backlashes rises when joint ``axis``'s backlash is left out: fitted only
    when a side is favoured (a side not favoured is not taken whatever it is)."""
    without = tuple(n for n in backlash if n != backlash[axis])
    return float(fit_many(variant, theta, BASE_MODEL, [without]).rss[0]) - rss
