"""Which effects to add: forward selection by nested-model tests and an information
criterion, one effect at a time and in pairs, until the fit is within the noise;
then a backward check that every effect kept still earns its place.

An addition is eligible when the data determine its parameters, its values are
plausible, its nested test is significant after a Bonferroni correction for the
candidates of its size (the best of 351 pairs always improves the fit somewhat),
and the BIC agrees it pays for its parameters. Among the eligible, parsimony first:
the best pair is taken when it beats the best single by more than the best of all
pairs would by chance, or the single plus a second when that beats it by more than
the best second would; else the single when it brings the fit within the noise, or
the pair when only the pair does; else the single, and the search goes on."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ogacq.diagnose.batchfit import CandidateFits, Design, Problem, fit_many
from ogacq.diagnose.library import BASE_MODEL, EFFECT_PARAMETERS, label, pairs, singles
from ogacq.diagnose.nested import bic_change, nested_test, nested_tests
from ogacq.identify.consistency import LEVEL, Verdict, judge
from ogacq.identify.noise import GaugeNoise
from ogacq.model.parameters import NOMINAL, PARAM_INDEX

MAX_EFFECTS = 4  # beyond this a "diagnosis" is a curve fit


@dataclass
class Model:
    """The joint offsets plus ``effects``, fitted."""

    effects: tuple[str, ...]
    theta: np.ndarray
    residuals: np.ndarray  # unweighted, gauge zeros removed, mm
    rss: float  # weighted
    rank: int  # parameters the data determine
    verdict: Verdict
    # unweighted, of ``names`` at ``theta``, when evaluated here (the verdict's): where
    # the misfit sits is found with the same one
    jacobian: np.ndarray | None = field(default=None, repr=False, compare=False)

    @property
    def names(self) -> tuple[str, ...]:
        return BASE_MODEL + self.effects

    def rms_by_gauge(self, gauges: np.ndarray) -> dict[str, float]:
        return {g: float(np.sqrt(np.mean(self.residuals[gauges == g] ** 2)))
                for g in dict.fromkeys(gauges.tolist())}


def evaluate(problem: Problem, noise: GaugeNoise, effects: tuple[str, ...],
             theta: np.ndarray, rank: int, alpha: float = LEVEL,
             jacobian: np.ndarray | None = None) -> Model:
    """The fitted model with its full verdict (overall test and worst cell).
    ``jacobian``: the unweighted Jacobian of its names at ``theta`` on
    ``problem.obs`` when the caller holds it (an exact fit's last), else evaluated."""
    residuals = problem.residuals(theta[None])[0]
    rss = float(np.sum(problem.weighted(residuals[None]) ** 2))
    jac = problem.jacobian(theta, BASE_MODEL + effects, weighted=False) if jacobian is None \
        else jacobian
    return Model(effects, theta, residuals, rss, rank,
                 judge(problem.obs, residuals, jac, rank, noise, alpha), jac)


@dataclass(frozen=True)
class Considered:
    """One candidate addition at one step."""

    added: tuple[str, ...]
    rss: float
    p_value: float  # nested test against the current model, Bonferroni-corrected
    reason: str  # "" when eligible, else why not

    @property
    def eligible(self) -> bool:
        return not self.reason


@dataclass
class SelectionStep:
    """One addition of the forward selection: the effects added and the tests that chose them."""

    before: Model
    after: Model
    added: tuple[str, ...]
    p_value: float
    delta_bic: float

    @property
    def label(self) -> str:
        return label(self.added)


@dataclass
class Selection:
    base: Model
    final: Model
    steps: list[SelectionStep] = field(default_factory=list)
    dropped: list[tuple[str, float]] = field(default_factory=list)  # (effect, p) removed
    last_considered: list[Considered] = field(default_factory=list)  # when stuck
    candidates_fitted: int = 0


def _consider(cands: CandidateFits, current: Model, problem: Problem, noise: GaugeNoise,
              alpha: float) -> list[Considered]:
    full, plausible = cands.full_rank(), cands.plausible()
    sizes = np.array([len(e) for e in cands.extras])
    searched = {size: int(np.sum(sizes == size)) for size in set(sizes.tolist())}
    dof = problem.n_data - cands.rank
    _, p = nested_tests(current.rss, cands.rss, cands.rank - current.rank, dof, noise)
    p = np.minimum(1.0, p * np.array([searched[n] for n in sizes]))
    bic = bic_change(current.rss - cands.rss, cands.rank - current.rank, problem.n_data, noise)
    # Python scalars, once: the loop below reads hundreds of candidates
    rss, finite, p_of, bic_of = cands.rss.tolist(), np.isfinite(cands.rss), p.tolist(), \
        bic.tolist()
    out = []
    for k, added in enumerate(cands.extras):
        if not full[k]:
            reason = "not determined by these data beside the model"
        elif not finite[k]:
            reason = "puts a posture out of reach"
        elif not plausible[k]:
            reason = "needs an implausible value"
        elif p_of[k] >= alpha:
            reason = f"not significant (p = {p_of[k]:.2g} after {searched[len(added)]} candidates)"
        elif bic_of[k] >= 0:
            reason = "does not pay for its parameters (BIC)"
        else:
            reason = ""
        out.append(Considered(added, rss[k], p_of[k], reason))
    return out


def _best(considered: list[Considered], size: int) -> Considered | None:
    pool = [c for c in considered if c.eligible and len(c.added) == size]
    return min(pool, key=lambda c: c.rss) if pool else None


def _choose(considered: list[Considered], full: Callable[[Considered], Model],
            noise: GaugeNoise, alpha: float) -> tuple[Considered, Model] | None:
    single, pair = _best(considered, 1), _best(considered, 2)
    if single is None or pair is None:
        chosen = single or pair
        return None if chosen is None else (chosen, full(chosen))
    # The best pair holding the best single: that single plus a second effect.
    extension = min((c for c in considered if c.eligible and len(c.added) == 2
                     and single.added[0] in c.added), key=lambda c: c.rss, default=None)
    models: dict[tuple[str, ...], Model] = {}

    def model(c: Considered) -> Model:
        """``full(c)``, made when first asked for: the choice below often needs only
        one or two of the three (each a verdict with its cell tests)."""
        if c.added not in models:
            models[c.added] = full(c)
        return models[c.added]

    def beats(better: Considered | None, candidates: int) -> bool:
        """Better than ``single`` (by its one more parameter) beyond what the best of
        that many chance candidates would give: the nested test, Bonferroni-corrected,
        as in the backward check."""
        if better is None:
            return False
        bigger = model(better)
        _, p = nested_test(single.rss, better.rss, 1, bigger.verdict.dof, noise)
        return p * candidates < alpha

    n_pairs = sum(len(c.added) == 2 for c in considered)
    n_second = sum(len(c.added) == 2 and single.added[0] in c.added for c in considered)
    if beats(pair, n_pairs):
        return pair, model(pair)
    if extension is not None and beats(extension, n_second):
        return extension, model(extension)
    if model(single).verdict.consistent or not model(pair).verdict.consistent:
        return single, model(single)
    return pair, model(pair)


def select(problem: Problem, noise: GaugeNoise, base: Model, *, alpha: float = LEVEL,
           design: Design | None = None) -> Selection:
    """``design``: the weighted Jacobian of the offsets and every effect at the base
    model's solution, when the caller holds it."""
    selection = Selection(base, base)
    current = base
    while current.verdict.state == "inconsistent" and len(current.effects) < MAX_EFFECTS:
        room = MAX_EFFECTS - len(current.effects)
        extras = singles(current.effects) + (pairs(current.effects) if room >= 2 else [])
        if current is not base or design is None:
            union = current.names + tuple(n for n in EFFECT_PARAMETERS
                                          if n not in current.names)
            design = Design(union, problem.jacobian(current.theta, union))
        cands = fit_many(problem, current.theta, current.names, extras, jac=design)
        selection.candidates_fitted += len(extras)
        considered = _consider(cands, current, problem, noise, alpha)

        def full(c: Considered, cands: CandidateFits = cands, current: Model = current) -> Model:
            k = cands.extras.index(c.added)
            return evaluate(problem, noise, current.effects + c.added, cands.theta[k],
                            int(cands.rank[k]), alpha)

        choice = _choose(considered, full, noise, alpha)
        if choice is None:
            selection.last_considered = sorted(considered, key=lambda c: c.rss)
            break
        chosen, after = choice
        drop, added = current.rss - after.rss, after.rank - current.rank
        selection.steps.append(SelectionStep(current, after, chosen.added, chosen.p_value,
                                             bic_change(drop, added, problem.n_data, noise)))
        current = after
    selection.final = _backward(problem, noise, current, alpha, selection)
    return selection


def _backward(problem: Problem, noise: GaugeNoise, model: Model, alpha: float,
              selection: Selection) -> Model:
    """Drop, one at a time, effects that the others have made redundant. Each effect
    was the best of the library's, so its test is corrected for that many."""
    while len(model.effects) > 1:
        pool = len(EFFECT_PARAMETERS) - len(model.effects) + 1
        fits = []
        for name in model.effects:
            kept = tuple(e for e in model.effects if e != name)
            start = model.theta.copy()
            start[PARAM_INDEX[name]] = NOMINAL[PARAM_INDEX[name]]
            cands = fit_many(problem, start, BASE_MODEL + kept, [()])
            _, p = nested_test(float(cands.rss[0]), model.rss,
                               model.rank - int(cands.rank[0]),
                               problem.n_data - model.rank, noise)
            fits.append((min(1.0, p * pool), name, kept, cands))
        p, name, kept, cands = max(fits, key=lambda t: t[0])
        if p < alpha:
            break
        selection.dropped.append((name, p))
        model = evaluate(problem, noise, kept, cands.theta[0], int(cands.rank[0]), alpha)
    return model
