"""A map's band widened by the models its readings cannot rule out.

The search stops on a model; the terms it left out are not known to be absent, only
not shown beyond its rules. One that the readings favour but whose pitch lies between
rival peaks (never added, ``mapsearch._unresolved_first``), or one just short of the
test, still moves the other maps where it would be fitted: a 1.3 µm lead of 12 mm on z
left out, the bend fitted on x took part of it and lay 4.9 of its own std from the
truth (bench/table_coverage.py, seed 4). A term a step weighed nearly as well as the
one it took moves them too: a 0.7 µm lead of 26 mm, seen strongly over only 16 mm of
its joint, was taken as a 5 µm cubic, 4.2 of its band from the truth (seed 165). Each
term left at the search's last step is fitted beside the chosen model, and each term a
step weighed is fitted in place of the one that step took; each is weighed against the
chosen model by the BIC (``exp(-dBIC / 2)``: the posterior odds of the two models
under equal priors, the BIC's approximation of the Bayes factor: R. E. Kass and A. E.
Raftery, J. Am. Stat. Assoc. 90, 1995, 773), and each map's band becomes the root mean
square of its error about the chosen map over the models so weighed (the variance of
Bayesian model averaging: J. A. Hoeting et al., Stat. Sci. 14, 1999, 382; about the
chosen map rather than the mean, since the chosen map is what a table corrects). Never
narrower than the chosen map's own band. The map itself is kept: a term the rules did
not take is not applied."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ogacq.diagnose.batchfit import Problem
from ogacq.diagnose.mapfit import MapFit, fit_with_maps
from ogacq.diagnose.mapsearch import MapCandidate, MapSearch
from ogacq.diagnose.nested import bic_change
from ogacq.identify.noise import GaugeNoise
from ogacq.model.axis_map import AxisMap
from ogacq.model.error_maps import JointHistory, MapTerm

# An alternative whose weight beside the chosen model is below this is not fitted: its
# share of a band is under a hundredth of its difference squared (no source).
WEIGHT_FLOOR = 0.01
# The most alternatives fitted (the best first by the search's own BIC): each is one
# refit of the whole model (no source: the search's last step holds about ten).
MOST = 4


@dataclass(frozen=True)
class MapAlternative:
    """A term the search left out, fitted beside the chosen model or in place of one
    of its terms (``in_place_of``), and its weight."""

    candidate: MapCandidate
    weight: float  # its posterior probability over the chosen model and the others
    fit: MapFit
    in_place_of: str | None = None

    def to_json(self) -> dict:
        return {"term": self.candidate.term.name, "weight": round(self.weight, 4),
                **({"in_place_of": self.in_place_of} if self.in_place_of else {})}


def odds(delta_bic: float) -> float:
    """The posterior odds of a model ``delta_bic`` above another (BIC); kept within
    the doubles where a model is overwhelmingly better."""
    return math.exp(-0.5 * max(delta_bic, -1400.0))


@dataclass(frozen=True)
class _Trial:
    """A model to weigh: the chosen terms with ``candidate`` added, or put in place of
    the chosen term ``replaced``; ``prior``: its odds by the search's own BIC."""

    candidate: MapCandidate
    replaced: MapCandidate | None
    prior: float

    def terms(self, chosen: list[MapTerm]) -> list[MapTerm]:
        if self.replaced is None:
            return [*chosen, self.candidate.term]
        gone = self.replaced.term.name
        return [self.candidate.term if t.name == gone else t for t in chosen]

    @property
    def parameters(self) -> int:
        """Its parameters beyond the chosen model's."""
        c, r = self.candidate, self.replaced
        return c.rank + c.shape_parameters - (0 if r is None else r.rank + r.shape_parameters)


def alternatives(problem: Problem, noise: GaugeNoise, fitted: MapFit, search: MapSearch,
                 history: JointHistory) -> tuple[MapAlternative, ...]:
    """The models that weigh ``WEIGHT_FLOOR`` or more beside ``fitted``: a term of the
    search's last step added, or a term a step weighed put in place of the one it
    took (a cubic taken for a long lead seen over 16 mm of the joint: its swap for
    the lead weighs as much, and the two part 4 µm at the travel's end). At most
    ``MOST``, each refitted (its BIC change exact), their weights normalised over
    the chosen model and them."""
    names = {t.name for t in fitted.terms}
    trials = [_Trial(c, None, odds(c.delta_bic)) for c in search.last_considered
              if c.rank > 0 and c.term.name not in names]
    for step in search.steps:
        trials += [_Trial(c, step.added, odds(c.delta_bic - step.added.delta_bic))
                   for c in step.considered if c.rank > 0 and c.term.name not in names]
    trials = sorted((t for t in trials if t.prior / (1.0 + t.prior) >= WEIGHT_FLOOR),
                    key=lambda t: -t.prior)[:MOST]
    weighed: list[tuple[_Trial, float, MapFit]] = []
    for trial in trials:
        alt = fit_with_maps(problem, noise, fitted.names, fitted.theta,
                            trial.terms(list(fitted.terms)), history)
        change = bic_change(fitted.rss - alt.rss, trial.parameters, problem.n_data, noise)
        weighed.append((trial, odds(change), alt))
    total = 1.0 + sum(o for _, o, _ in weighed)
    return tuple(MapAlternative(t.candidate, o / total, alt,
                                None if t.replaced is None else t.replaced.term.name)
                 for t, o, alt in weighed if o / total >= WEIGHT_FLOOR)


def widened(maps: Sequence[AxisMap], alternatives_: Sequence[MapAlternative],
            tabulate: Callable[[MapAlternative], Sequence[AxisMap]]) -> tuple[AxisMap, ...]:
    """``maps`` with each band the root mean square about it over the chosen model and
    ``alternatives_`` (``tabulate``: an alternative's maps over the same ranges, zero at
    the same references); unchanged without alternatives."""
    if not alternatives_:
        return tuple(maps)
    chosen = 1.0 - sum(a.weight for a in alternatives_)
    variance = {m.axis: {side: chosen * np.square(u) for side, u in _bands(m).items()}
                for m in maps}
    for alt in alternatives_:
        theirs = {m.axis: m for m in tabulate(alt)}
        for m in maps:
            # no map on the axis in that model: there, its error is none
            other = theirs.get(m.axis, _none_like(m))
            at = np.asarray(m.positions_mm)
            for side in (1, -1):
                gap = other.error_mm(at, side) - m.error_mm(at, side)
                band = np.interp(at, other.positions_mm, _bands(other)[side])
                variance[m.axis][side] += alt.weight * (np.square(gap) + np.square(band))
    out = []
    for m in maps:
        own = _bands(m)
        u = {side: np.maximum(np.sqrt(v), own[side]) for side, v in variance[m.axis].items()}
        out.append(dataclasses.replace(
            m, u_forward_mm=tuple(u[1].tolist()), u_reverse_mm=tuple(u[-1].tolist()),
            extra={**m.extra, "band_alternatives": [a.to_json() for a in alternatives_]}))
    return tuple(out)


def _none_like(m: AxisMap) -> AxisMap:
    zero = (0.0,) * len(m.positions_mm)
    return dataclasses.replace(m, forward_mm=zero, reverse_mm=zero, u_forward_mm=zero,
                               u_reverse_mm=zero)


def _bands(m: AxisMap) -> dict[int, np.ndarray]:
    return {1: np.asarray(m.u_forward_mm), -1: np.asarray(m.u_reverse_mm)}
