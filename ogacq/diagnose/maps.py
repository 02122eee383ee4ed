"""The diagnosis's second look: errors along each axis and in time beside the library
(``mapsearch.py``), library effects they make redundant dropped, the model refitted
with them (``mapfit.py``); the maps tabulated only when that fit is within the gauge
noise (else "not established", and no table nor ISO 230-2 figure is made of them);
alternatives both ways and the scans that would separate them (``mapswap.py``)."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from ogacq.diagnose.alternatives import Alternative
from ogacq.diagnose.batchfit import Problem
from ogacq.diagnose.library import BASE_MODEL, EFFECT_PARAMETERS, entry, label
from ogacq.diagnose.mapaverage import MapAlternative, alternatives, widened
from ogacq.diagnose.mapfit import (
    MapFit,
    axis_maps,
    fit_with_maps,
    map_columns,
)
from ogacq.diagnose.mappolish import polished
from ogacq.diagnose.mapsearch import RIVALS, AxisCoverage, MapSearch, search_maps
from ogacq.diagnose.mapswap import (
    Proposal,
    ScanSignatures,
    library_swaps,
    linearised,
    map_swaps,
    propose,
    swap_families,
)
from ogacq.diagnose.nested import nested_test
from ogacq.diagnose.selection import Model
from ogacq.identify.consistency import LEVEL
from ogacq.identify.noise import GaugeNoise, noise_for
from ogacq.identify.observations import Observations
from ogacq.identify.search_rules import SWAP_CHI2
from ogacq.model.axis_map import AxisMap
from ogacq.model.error_maps import JointHistory, MapTerm, ShapeSpread
from ogacq.model.families import MapValue
from ogacq.model.gauges import AXES
from ogacq.model.parameters import NOMINAL, PARAM_INDEX
from ogacq.model.units import json_number

UNIT_MM = "mm"
# Library effects and maps together that are not taken as settled while the maps from
# the joint offsets alone stopped on an unresolved pitch (issue 37: "no combination of
# three or more effects is chosen over one map without a test that prefers it").
MANY_TERMS = 3
# what an explanation adds to the rest of a model: values, library names, map terms
Explanation = tuple[np.ndarray, list[str], list[MapTerm]]


@dataclass
class MapEffect:
    """A map term of the final model: its value (mm) and std (inflated like every
    effect's when the final fit is not within the noise), its further parameters,
    its test, what else explains the readings as well."""

    term: MapTerm
    value: MapValue
    std: float
    p_value: float
    delta_chi2: float  # by how much it lowered the chi-square when added
    alternatives: list[Alternative] = field(default_factory=list)
    coverage: AxisCoverage | None = None
    # as a library effect's (``diagnosis.EffectFound``), for the readers of both
    separations: list = field(default_factory=list)
    model_spread: float = 0.0
    local_disturbance: str | None = None
    # whether the final fit with it is within the gauge noise: a map beside a misfit
    # nothing explains may stand for that misfit, and is not presented as found
    established: bool = True

    def not_established(self) -> str | None:
        """Why this map is not taken as found, and what would establish it (None when
        it is)."""
        if self.established:
            return None
        return ("not established: the final fit is NOT within the gauge noise, so this map "
                "may stand in for the misfit left; no table is made of it. What would "
                "establish it: that misfit explained, or a scan of this axis, denser, "
                "at irregular positions and from both sides, whose fit is within the noise")

    @property
    def name(self) -> str:
        return self.term.name

    @property
    def ambiguous(self) -> bool:
        return bool(self.alternatives)

    @property
    def unit(self) -> str:
        return UNIT_MM

    def sentence(self) -> str:
        """Where along which axis and what: "x axis, q from -100 to +60 mm, cyclic
        lead-screw error of pitch 5.00 mm, about 4.8 µm"."""
        t, v = self.term, self.value
        where = f"{AXES[t.axis]} axis"
        if self.coverage is not None:
            where += f", q from {self.coverage.from_mm:+g} to {self.coverage.to_mm:+g} mm"
        return f"{where}, {t.kind.sentence(t, v)}, {t.kind.size_words(v)}"

    def to_json(self) -> dict:
        return {**entry(self.name), "value": round(float(self.value.value), 6),
                "std": json_number(self.std, 6), "unit": self.unit,
                "alternatives": [entry(a.name) for a in self.alternatives],
                "family": "error map", "p_value": float(f"{self.p_value:.3g}"),
                "delta_chi2": round(self.delta_chi2, 1), "located": self.sentence(),
                "established": self.established, **self.value.extra}


@dataclass(frozen=True)
class Rival:
    """The explanation not chosen that fits the readings as well: library effects with
    maps found beside them, against maps alone searched from the joint offsets.
    ``chosen``/``other``: each as (values, library names, map terms) of what it adds to
    the joint offsets; ``delta_chi2``: the other's chi-square minus the chosen one's;
    ``p_library``: the library effects' nested test beside the maps alone (corrected
    for the library's size): the test that decides between them."""

    chosen: Explanation
    other: Explanation
    delta_chi2: float
    p_library: float

    @staticmethod
    def label(explanation: Explanation) -> str:
        return label((*explanation[1], *(t.name for t in explanation[2])))

    def describe(self) -> str:
        library = self.chosen[1] or self.other[1]
        significant = "significant" if self.chosen[1] else "not significant"
        return (f"{self.label(self.other)} explains the readings as well "
                f"(chi2 {self.delta_chi2:+.1f}); chosen: {', '.join(library)} {significant} "
                f"beside the maps alone (p = {self.p_library:.2g})")


@dataclass
class MapOutcome:
    """What the map search found and the final model with it."""

    search: MapSearch
    fit: MapFit | None  # None: no map found (the library's model is final)
    effects: list[MapEffect]
    dropped: list[tuple[str, float]]  # library effects the maps made redundant, with p
    maps: tuple[AxisMap, ...]
    # library effect -> map terms explaining the readings as well in its place
    library_alternatives: dict[str, list[Alternative]]
    proposals: list[Proposal]
    chi2_before: float  # the library model's chi-square (weighted rss / variance)
    chi2_after: float
    inflation: float = 1.0  # on the maps' std: the final fit's misfit beyond the noise
    # the other route's explanation when it fits as well (``Rival``), else None
    rival: Rival | None = None
    # terms the search left out that the readings do not rule out: the maps' bands
    # hold what each would change of them, by its weight (``mapaverage.py``)
    band_alternatives: tuple[MapAlternative, ...] = ()
    # each term's shape parameter as known (a pitch's std and profile path), by name
    spreads: dict[str, ShapeSpread] = field(default_factory=dict)

    @property
    def established(self) -> bool:
        """Maps were found and the final fit with them is within the gauge noise: only
        then are they tabulated (``maps``, ``maps_over``, ``value_at``)."""
        return self.fit is not None and self.fit.verdict.consistent

    def maps_over(self, spans: Mapping[int, tuple[float, float]],
                  zero_at: Mapping[int, float] | None = None) -> tuple[AxisMap, ...]:
        """The maps tabulated over what the campaign read of each axis widened to
        ``spans`` (axis -> from, to; mm of q): where a compensation must hold beyond the
        readings (the travel's ends, or a travel moved by new joint offsets), the fitted
        shapes go on (a periodic error its period, a spline its end cubic, a wound-up
        hysteresis its value), their band from the fit's covariance and the pitch's std
        (which grows with the distance from the reference). Zero at ``zero_at`` (axis
        -> q) where given, the band relative to it. ``extra["measured_mm"]`` says where
        the readings were."""
        if self.fit is None or not self.established:
            return ()
        covs = {c.axis: c for c in self.search.coverage}
        ranges = {}
        for a, c in covs.items():
            lo, hi = spans.get(a, (c.from_mm, c.to_mm))
            ranges[a] = (min(lo, c.from_mm), max(hi, c.to_mm))
        maps = self.tabulated(ranges, zero_at)
        return tuple(dataclasses.replace(m, extra={**m.extra, "measured_mm": [
            covs[AXES.index(m.axis)].from_mm, covs[AXES.index(m.axis)].to_mm]})
            for m in maps)

    def tabulated(self, ranges: Mapping[int, tuple[float, float]],
                  zero_at: Mapping[int, float] | None = None) -> tuple[AxisMap, ...]:
        """The final fit's maps over ``ranges``, their bands widened by the models the
        readings do not rule out (``band_alternatives``)."""
        assert self.fit is not None
        steps = {c.axis: c.step_mm for c in self.search.coverage}
        spreads = self.spreads
        maps = axis_maps(self.fit, self.inflation, ranges, steps, spreads, zero_at)

        def tabulate(alt: MapAlternative) -> tuple[AxisMap, ...]:
            term = alt.candidate.term
            return axis_maps(alt.fit, max(self.inflation, alt.fit.verdict.inflation), ranges,
                             steps, {**spreads, term.name: alt.candidate.spread}, zero_at)

        return widened(maps, self.band_alternatives, tabulate)

    def value_at(self, axis: int, q_mm: float) -> float:
        """The axis's map (its along-the-line terms summed, as the diagnosis fitted them,
        zero at their reference) at ``q_mm`` approached forward: the constant a map
        made zero elsewhere (``maps_over``'s ``zero_at``) hands to the joint offset."""
        if self.fit is None or not self.established:
            return 0.0
        total = 0.0
        at = np.array([q_mm])
        for term, coef in zip(self.fit.terms, self.fit.coefficients, strict=True):
            if term.axis == axis and term.tabulated:
                shape = term.shape_of(at, np.ones(1), np.full(1, np.inf), np.zeros(1))
                total += float(coef @ shape[:, 0])
        return total


def _backward(problem: Problem, noise: GaugeNoise, claimed: Model, terms: list[MapTerm],
              history: JointHistory, alpha: float) -> tuple[tuple[str, ...], list]:
    """Drop, one at a time, library effects that the maps have made redundant: the
    linear model about the library's solution, each effect's column left out in turn;
    its test corrected for the library's size (each was the best of that many)."""
    effects = list(claimed.effects)
    dropped: list[tuple[str, float]] = []
    if not effects or not terms:
        return claimed.names, dropped
    theta = claimed.theta
    maps = problem.weighted(map_columns(problem, theta, terms, history).T).T
    lib = problem.jacobian(theta, claimed.names) if claimed.jacobian is None \
        else problem.weighted_jacobian(claimed.jacobian)
    # the readings as seen from the offsets with every effect at nominal
    target = problem.weighted_residuals(theta[None])[0] + sum(
        (lib[:, claimed.names.index(e)] * (theta[PARAM_INDEX[e]] - NOMINAL[PARAM_INDEX[e]])
         for e in effects), np.zeros(len(lib)))

    def rss_of(names: list[str]) -> tuple[float, int]:
        x = np.column_stack([lib[:, [claimed.names.index(n) for n in names]], maps])
        norm = np.maximum(np.linalg.norm(x, axis=0), 1e-300)
        coef, _, rank, _ = np.linalg.lstsq(x / norm, target, rcond=1e-10)
        rest = target - (x / norm) @ coef
        return float(rest @ rest), int(rank)

    while effects:
        names = list(BASE_MODEL) + effects
        rss, rank = rss_of(names)
        pool = len(EFFECT_PARAMETERS) - len(effects) + 1
        tests = []
        for e in effects:
            rss_without, rank_without = rss_of([n for n in names if n != e])
            _, p = nested_test(rss_without, rss, max(rank - rank_without, 1),
                               problem.n_data - rank, noise)
            tests.append((min(1.0, p * pool), e))
        p, worst = max(tests)
        if p < alpha:
            break
        effects.remove(worst)
        dropped.append((worst, p))
    return BASE_MODEL + tuple(effects), dropped


@dataclass
class _Route:
    """The maps searched beside one starting model, its library effects the maps made
    redundant dropped, the final model refitted with them."""

    start: Model
    search: MapSearch
    names: tuple[str, ...]
    dropped: list[tuple[str, float]]
    fit: MapFit | None

    @property
    def rss(self) -> float:
        return self.start.rss if self.fit is None else self.fit.rss

    @property
    def consistent(self) -> bool:
        return self.start.verdict.consistent if self.fit is None else \
            self.fit.verdict.consistent

    def explanation(self) -> Explanation:
        """What it adds to the joint offsets: library values, names, map terms."""
        library = [n for n in self.names if n not in BASE_MODEL]
        theta = self.start.theta if self.fit is None else self.fit.theta
        values = [theta[PARAM_INDEX[n]] - NOMINAL[PARAM_INDEX[n]] for n in library]
        if self.fit is not None:
            values += [c for coef in self.fit.coefficients for c in coef]
        return (np.array(values), library, [] if self.fit is None else list(self.fit.terms))


def _route(problem: Problem, noise: GaugeNoise, start: Model, alpha: float,
           history: JointHistory, band: tuple[float, float] | None) -> _Route:
    search = search_maps(problem, noise, start.theta, start.names, start.rss,
                         start.verdict.consistent, alpha, jacobian=start.jacobian,
                         pitch_band_mm=band)
    terms = search.terms
    if not terms:
        return _Route(start, search, start.names, [], None)
    names, dropped = _backward(problem, noise, start, terms, history, alpha)
    # a map searched beside an effect now dropped takes its part (a smooth map found
    # without its slope beside the axis's encoder scale takes the slope): left to
    # neither, a bend's slope of 45 um/m was corrected by nothing, and the map's band,
    # certain of a slope it did not hold, left the error 11.7 times it at -80 mm
    theta0 = start.theta.copy()
    for name, _ in dropped:
        terms = [t.kind.in_place_of(t, name) for t in terms]
        theta0[PARAM_INDEX[name]] = NOMINAL[PARAM_INDEX[name]]
    # the start's Jacobian is the start's when no effect was dropped
    fitted = fit_with_maps(problem, noise, names, theta0, terms, history, alpha=alpha,
                           jacobian0=None if dropped else start.jacobian)
    return _Route(start, search, names, dropped, fitted)


def _library_beside_maps(problem: Problem, noise: GaugeNoise, library: _Route,
                         alone: _Route, history: JointHistory) -> tuple[float, int]:
    """p of the library effects of ``library`` added to the maps found alone (both
    fitted together), corrected for the library's size as the backward check is,
    and the rank they add (0: the maps hold them, as a screw map holds a scale)."""
    assert alone.fit is not None
    effects = [n for n in library.names if n not in BASE_MODEL]
    theta0 = alone.fit.theta.copy()
    theta = library.start.theta if library.fit is None else library.fit.theta
    for n in effects:
        theta0[PARAM_INDEX[n]] = theta[PARAM_INDEX[n]]
    both = fit_with_maps(problem, noise, BASE_MODEL + tuple(effects), theta0, alone.fit.terms,
                         history, iterations=1)
    added = both.rank - alone.fit.rank
    _, p = nested_test(alone.fit.rss, both.rss, max(added, 1), problem.n_data - both.rank,
                       noise)
    return min(1.0, p * len(EFFECT_PARAMETERS)), added


def _chosen_route(problem: Problem, noise: GaugeNoise, library: _Route, base: Model | None,
                  alpha: float, history: JointHistory, band: tuple[float, float] | None,
                  ) -> tuple[_Route, Rival | None]:
    """The library's route, or the maps searched from the joint offsets alone where
    those are fewer, within the noise, and the library's effects are not significant
    beside them: a combination of library effects and maps is not chosen over fewer
    maps without a test that prefers it. When both fit as well (their chi-square
    within ``SWAP_CHI2``), the other is the rival, to be named with the scan that
    separates them."""
    effects = [n for n in library.names if n not in BASE_MODEL]
    if base is None or not effects or library.fit is None:
        return library, None  # no library effect, or no map beside them
    alone = _route(problem, noise, base, alpha, history, band)
    if alone.fit is None and len(effects) + len(library.fit.terms) >= MANY_TERMS:
        # not settled while the maps alone stopped on a pitch between rival peaks: a
        # combination stands in for the one error no scan has yet resolved (a 2 um
        # lead of 22.9 mm beside a bend read as a leg length and three rail bows)
        library.search.unresolved_alone = [c for c in alone.search.unresolved
                                           if c.unresolved.startswith(RIVALS)]
    # only a simpler explanation is weighed against the library's: a backlash is not
    # renamed a hysteresis of no length, which is the same physics
    if alone.fit is None or not alone.consistent or \
            len(alone.fit.terms) >= len(effects) + len(library.fit.terms):
        return library, None
    p, added = _library_beside_maps(problem, noise, library, alone, history)
    scale = noise.variance * max(1.0, alone.fit.verdict.chi2_dof)
    if p >= alpha:
        chosen, other = alone, library
        chosen.dropped = [(n, p) for n in library.start.effects]
    else:
        chosen, other = library, alone
    gap = (other.rss - chosen.rss) / scale
    # the maps alone holding the library's effects, no measurement tells them apart
    rival = Rival(chosen.explanation(), other.explanation(), gap, p) \
        if gap < SWAP_CHI2 and added > 0 else None
    return chosen, rival


def map_diagnosis(problem: Problem, noise: GaugeNoise, claimed: Model, alpha: float = LEVEL,
                  separate: bool = True, base: Model | None = None,
                  pitch_band_mm: tuple[float, float] | None = None) -> MapOutcome:
    """Search, refit and judge the maps beside the library's ``claimed`` model, and
    beside the joint offsets alone (``base``) where the library claimed effects;
    ``pitch_band_mm``: the periods a designed scan's positions sample."""
    history = JointHistory.of(problem.obs.layout)
    library = _route(problem, noise, claimed, alpha, history, pitch_band_mm)
    route, rival = _chosen_route(problem, noise, library, base, alpha, history,
                                 pitch_band_mm)
    search, fitted, dropped = route.search, route.fit, route.dropped
    chi2_before = claimed.rss / noise.variance
    covs = {c.axis: c for c in search.coverage}
    spreads = {s.added.term.name: s.added.spread for s in search.steps}
    if fitted is not None:
        fitted, spreads = polished(problem, noise, fitted, history, spreads, alpha)
    inflation = 1.0 if fitted is None else fitted.verdict.inflation
    effects = []
    established = fitted is not None and fitted.verdict.consistent
    if fitted is not None:
        added = {s.added.term.name: s for s in search.steps}
        for k, term in enumerate(fitted.terms):
            step = added[term.name]
            value = term.kind.value(term, fitted.coefficients[k], fitted.term_covariance(k)
                                    * inflation**2, spreads[term.name].std * inflation)
            effects.append(MapEffect(term, value, value.std, step.added.p_value,
                                     (step.rss_before - step.rss_after) / noise.variance,
                                     coverage=covs.get(term.axis), established=established))
    outcome = MapOutcome(search, fitted, effects, dropped, (), {}, [], chi2_before,
                         (route.rss if fitted is None else fitted.rss) / noise.variance,
                         inflation, rival, spreads=spreads)
    if fitted is not None and established:
        outcome.band_alternatives = alternatives(problem, noise, fitted, search, history)
        outcome.maps = outcome.tabulated({a: (c.from_mm, c.to_mm) for a, c in covs.items()})
    if separate and problem.obs.raw and search.coverage:
        _honesty(problem, noise, claimed, outcome, history, inflation)
    return outcome


def _honesty(problem: Problem, noise: GaugeNoise, claimed: Model, outcome: MapOutcome,
             history: JointHistory, inflation: float) -> None:
    """Alternatives both ways between the library's effects and the maps, and the scans
    that would tell each pair apart."""
    fitted = outcome.fit
    if fitted is None:  # the library's model, as a map fit without maps
        fitted = fit_with_maps(problem, noise, claimed.names, claimed.theta, [], history,
                               iterations=1, jacobian0=claimed.jacobian)
    library_effects = tuple(n for n in fitted.names if n not in BASE_MODEL)
    if not library_effects and not fitted.terms:
        return
    lin = linearised(problem, noise, fitted, history, inflation)
    taken = {t.name for t in fitted.terms}
    candidates = swap_families(outcome.search.coverage, fitted.names, taken)
    swaps = library_swaps(lin, library_effects, candidates) if library_effects else {}
    outside = tuple(n for n in EFFECT_PARAMETERS if n not in fitted.names)
    per_map = map_swaps(lin, outside, candidates) if fitted.terms else {}
    signatures = ScanSignatures(problem.obs.machine, noise, fitted.theta, fitted.names,
                                fitted.terms)
    proposals: list[Proposal] = []
    for name, found in swaps.items():
        outcome.library_alternatives[name] = [a for _, a in found]
        for term, alt in found[:2]:
            k = PARAM_INDEX[name]
            one: Explanation = (np.array([fitted.theta[k] - NOMINAL[k]]), [name], [])
            other: Explanation = (lin.in_place(lin.without_effect(name), term), [], [term])
            proposals.append(propose(signatures, name, term.name, one, other,
                                     alt.delta_chi2))
    for effect in outcome.effects:
        effect.alternatives = per_map.get(effect.name, [])
        k = fitted.terms.index(effect.term)
        for alt in effect.alternatives[:2]:
            one = (fitted.coefficients[k], [], [effect.term])
            if alt.name in PARAM_INDEX:
                j = PARAM_INDEX[alt.name]
                other = (np.array([alt.value - NOMINAL[j]]), [alt.name], [])
            else:
                term = next(t for t in candidates if t.name == alt.name)
                other = (lin.in_place(lin.without_term(k), term), [], [term])
            proposals.append(propose(signatures, effect.name, alt.name, one, other,
                                     alt.delta_chi2))
    rival = outcome.rival
    if rival is not None:
        proposals.append(propose(signatures, Rival.label(rival.chosen),
                                 Rival.label(rival.other), rival.chosen, rival.other,
                                 rival.delta_chi2))
    outcome.proposals = proposals


def maps_left(obs: Observations, names: tuple[str, ...], theta: np.ndarray,
              written: Mapping[int, tuple[list[MapTerm], tuple[float, float], float]],
              coverage: Sequence[AxisCoverage]) -> tuple[AxisMap, ...]:
    """What is left of maps applied while ``obs`` was read: per axis (``written``: its
    terms as written, the range of its table and its reference), the terms at their
    written shapes fitted again beside the model ``names`` (from ``theta``), tabulated
    over that range, zero at that reference: what a correction left of the error it was
    made for, with its band. Only on axes the campaign read densely enough to search
    (``coverage``); none elsewhere."""
    dense = {c.axis: c for c in coverage if c.dense}
    todo = {a: w for a, w in written.items() if a in dense and w[0]}
    if not todo:
        return ()
    noise = noise_for(obs)
    problem = Problem(obs, noise)
    terms = [t for a in sorted(todo) for t in todo[a][0]]
    fitted = fit_with_maps(problem, noise, names, theta, terms, JointHistory.of(obs.layout))
    return axis_maps(fitted, fitted.verdict.inflation, {a: todo[a][1] for a in todo},
                     {a: dense[a].step_mm for a in todo}, zero_at={a: todo[a][2] for a in todo})
