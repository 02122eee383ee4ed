"""The diagnosis of one data set (``diagnose``): the verdict, where the misfit sits, the
library's effects selected until within the noise (claimed only when they explain
most of the misfit), their alternatives and the plans that would separate them; then
the error maps beyond the library (``maps.py``) and the misfit along each leg."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ogacq.diagnose.alternatives import Alternative, alternatives
from ogacq.diagnose.batchfit import Design, Problem
from ogacq.diagnose.library import BASE_MODEL, EFFECT_PARAMETERS, entry, unit
from ogacq.diagnose.locate import Location, locate
from ogacq.diagnose.mapfit import as_fit_result
from ogacq.diagnose.maps import MapEffect, MapOutcome, map_diagnosis
from ogacq.diagnose.mapswap import exploration
from ogacq.diagnose.outcome import outcome_label
from ogacq.diagnose.outliers import Outliers, find_outliers
from ogacq.diagnose.profile import LegProfile, leg_profiles
from ogacq.diagnose.robustness import resting_cell
from ogacq.diagnose.selection import Model, Selection, evaluate, select
from ogacq.diagnose.separation import (
    PlanOption,
    PlanSignatures,
    Separation,
    plan_capabilities,
    separation,
)
from ogacq.diagnose.sides import SideChoice, resolve_sides
from ogacq.diagnose.visibility import Capability, capability
from ogacq.errors import InputError
from ogacq.identify.consistency import LEVEL, Verdict
from ogacq.identify.fit import FitResult, fit
from ogacq.identify.noise import GaugeNoise, noise_for
from ogacq.identify.observations import Observations
from ogacq.model.axis_map import AxisMap
from ogacq.model.parameters import AXES, PARAM_INDEX, nested
from ogacq.model.units import json_number

SEPARATED_ALTERNATIVES = 4  # per effect, the closest ones get a separating plan
# When no set of effects brings the fit within the noise, those found are still
# reported if they remove at least this share of the misfit beyond the noise: a
# strong effect beside a small unknown one. Below it they are a partial curve fit
# of something outside the library (a lead-screw error fitted by leg lengths
# removes 25-60 % in our simulations) and naming them would mislead.
PARTIAL_SHARE = 0.75
FEW_POSTURES = 3  # at most this many positions per leg: errors in q are seen at 3 points


class DiagnosisError(InputError):
    """The data cannot be diagnosed (the base fit itself fails)."""

    def __init__(self, problem: str) -> None:
        super().__init__(None, problem)


@dataclass
class EffectFound:
    name: str
    value: float
    # From the gauge noise (inflated when the final fit is not within it), widened by
    # ``model_spread``: how far the value moves when another effect of the model is
    # swapped for one of its alternatives.
    std: float
    alternatives: list[Alternative]
    separations: list[Separation]
    model_spread: float = 0.0
    # A disturbance of this cell ("y_x at max") explains the data as well: the
    # effect's evidence rests on that cell alone.
    local_disturbance: str | None = None

    @property
    def unit(self) -> str:
        return unit(self.name)

    @property
    def ambiguous(self) -> bool:
        return bool(self.alternatives) or self.local_disturbance is not None

    def to_json(self) -> dict:
        alternatives = [entry(a.name) for a in self.alternatives]
        if self.local_disturbance is not None:
            gauge = self.local_disturbance.split(" at ")[0]
            alternatives.append({"effect": "unexplained", "where": gauge})
        return {**entry(self.name), "value": round(float(self.value), 6),
                "std": json_number(self.std, 6), "unit": self.unit, "alternatives": alternatives}


@dataclass
class Diagnosis:
    """``effects``: the library's effects of the final model, then its error maps
    (``maps.MapEffect``, the same fields the report and the terminal read)."""

    source: str
    kind: str  # "readings" or "deviations"
    n_observations: int
    noise: GaugeNoise
    capability: Capability
    selection: Selection  # the whole search, claimed or not
    claimed: Model  # the model reported as final
    explained_share: float  # of the base misfit beyond the noise, by the search's model
    base_fit: FitResult
    final_fit: FitResult
    located: Location  # the base model's misfit
    remaining: Location  # the final model's misfit
    effects: list[EffectFound | MapEffect]
    std_inflation: float  # factor on the final std (1 when within the noise)
    postures_per_leg: int
    plans: list[tuple[PlanOption, Capability]] = field(default_factory=list)
    mapped: MapOutcome | None = None  # the map search (None: not run)
    profiles: tuple[LegProfile, ...] = ()  # residuals along each scanned leg
    sides: list[SideChoice] = field(default_factory=list)  # unknown sides resolved
    outliers: Outliers | None = None  # readings far from their agreeing repeats

    @property
    def base(self) -> Verdict:
        return self.selection.base.verdict

    @property
    def final(self) -> Verdict:
        if self.mapped is not None and self.mapped.fit is not None:
            return self.mapped.fit.verdict
        return self.claimed.verdict

    @property
    def maps(self) -> tuple[AxisMap, ...]:
        """The error map of each actuator with one, for its compensation table."""
        return () if self.mapped is None else self.mapped.maps

    def maps_over(self, spans: Mapping[str, tuple[float, float]],
                  zero_at: Mapping[str, float] | None = None) -> tuple[AxisMap, ...]:
        """The maps tabulated beyond the readings, over ``spans`` (axis -> from, to), zero
        at ``zero_at`` (axis -> q): what a compensation of the whole travel needs
        (``MapOutcome.maps_over``)."""
        if self.mapped is None:
            return ()
        return self.mapped.maps_over({AXES.index(a): span for a, span in spans.items()},
                                     {AXES.index(a): q for a, q in (zero_at or {}).items()})

    def map_value_at(self, axis: str, q_mm: float) -> float:
        """The axis's map at ``q_mm`` forward, as fitted (0 without one)."""
        return 0.0 if self.mapped is None else self.mapped.value_at(AXES.index(axis), q_mm)

    @property
    def map_effects(self) -> list[MapEffect]:
        return [e for e in self.effects if isinstance(e, MapEffect)]

    @property
    def proposals(self) -> list:
        """Scans that would separate what these readings cannot (``mapswap.Proposal``);
        one that maps every axis when the fit is not explained and no axis was read
        densely enough to search."""
        out = [] if self.mapped is None else list(self.mapped.proposals)
        if not out and self.mapped is not None and not self.final.consistent \
                and self.final.judged and not any(c.dense for c in self.mapped.search.coverage):
            out.append(exploration(self.base_fit.observations.machine))
        return out

    @property
    def outcome(self) -> str:
        return outcome_label(self.base.consistent, self.final.consistent, bool(self.effects),
                             self.base.judged)

    @property
    def unexplained(self) -> str | None:
        """Where the misfit no effect explains sits; None when the fit is within noise."""
        return None if self.final.consistent or not self.final.judged else \
            self.remaining.where()

    def confident(self) -> list[str]:
        """Effects claimed with confidence: the fit is within the noise with them and
        nothing else in the library explains the data equally well."""
        if not self.final.consistent:
            return []
        return [e.name for e in self.effects if not e.ambiguous]

    def caveats(self) -> list[str]:
        out = []
        if self.effects and self.postures_per_leg <= FEW_POSTURES:
            out.append(f"with {self.postures_per_leg} positions per leg, an error that depends "
                       "on the joint position in another way (a lead-screw pitch error) is "
                       "seen at those points only and may pass for these effects; "
                       "a scan along each leg would show it")
        out += [c.describe() for c in self.sides if c.side]
        if self.mapped is not None:
            for cov in self.mapped.search.coverage:
                if not cov.searchable and (self.map_effects or not self.final.consistent):
                    out.append(cov.describe())
        if self.noise.source == "repeated readings" and any(
                n.startswith("thermal_drift") for n in self.capability.identifiable()):
            out.append("the noise is measured from repeated readings, whose scatter also "
                       "holds any drift between cycles: state the gauge repeatability in the "
                       "machine file to judge drift against the gauge alone")
        return out

    def unexplained_along(self) -> dict | None:
        """Where along a scanned leg the misfit left unexplained sits."""
        if self.unexplained is None:
            return None
        spans = [(p, p.beyond(self.noise.sigma_mm, after=True)) for p in self.profiles]
        hot = [(p, s) for p, s in spans if s is not None]
        if not hot:
            return None
        p, (lo, hi) = max(hot, key=lambda t: float(np.nanmax(t[0].rms_after_mm)))
        return {"leg": AXES[p.leg], "from_mm": lo, "to_mm": hi}

    def to_json(self) -> dict:
        """INTERCHANGE.md's object, plus keys beyond the contract (docs/formats.md): each
        map effect's further parameters, ``maps``, ``proposals``, ``coverage``,
        ``unknown_sides``, ``profiles``, ``chi2`` and ``outliers``."""
        effects = [e.to_json() for e in self.effects]
        if self.unexplained is not None:
            entry_: dict[str, Any] = {"effect": "unexplained", "where": self.unexplained,
                                      "value": None, "std": None, "unit": "-",
                                      "alternatives": []}
            along = self.unexplained_along()
            if along is not None:
                entry_["along"] = along
            effects.append(entry_)
        offsets = [self.final_fit.value(n) for n in BASE_MODEL]
        out = {"noise_mm": round(self.noise.sigma_mm, 6),
               "base": self.base.to_json(), "final": self.final.to_json(),
               "located": self.located.gauges_json(), "effects": effects,
               "parameters": nested(BASE_MODEL, [round(float(v), 6) for v in offsets])}
        if self.mapped is not None:
            out["maps"] = [m.to_json() for m in self.maps]
            out["proposals"] = [p.to_json() for p in self.proposals]
            out["coverage"] = [{"axis": AXES[c.axis], "positions": c.positions,
                                "from_mm": c.from_mm, "to_mm": c.to_mm,
                                "step_mm": c.step_mm if np.isfinite(c.step_mm) else None,
                                "both_sides": c.both_sides, "maps_searched": c.searchable}
                               for c in self.mapped.search.coverage]
            out["chi2"] = self.chi2_json()
        if self.sides:
            out["unknown_sides"] = [{"axis": AXES[c.axis], "taken": c.side,
                                     "readings": c.readings,
                                     "chi2_gain": round(c.gain_chi2, 2)} for c in self.sides]
        if self.profiles:
            out["profiles"] = [p.to_json() for p in self.profiles]
        if self.outliers is not None:
            out["outliers"] = self.outliers.to_json()
        return out

    def chi2_json(self) -> dict:
        """The chi-square and p of the library's model and of the final one (with the
        maps): the improvement the maps bring."""
        library, final = self.claimed.verdict, self.final

        def one(v: Verdict) -> dict:
            return {"statistic": round(float(v.statistic), 3) if np.isfinite(v.statistic)
                    else None, "dof": v.dof, "test": v.test,
                    "p": float(f"{v.overall_p:.4g}"), "consistent": v.consistent}

        return {"base": one(self.base), "library": one(library), "final": one(final)}


def _refit(obs: Observations, names: tuple[str, ...], noise: GaugeNoise,
           theta0: np.ndarray | None = None) -> FitResult:
    result = fit(obs, names, method="exact", weighting="gls", noise=noise, theta0=theta0)
    if not result.converged or not np.all(np.isfinite(result.residuals)):
        raise DiagnosisError(f"the fit of {', '.join(names)} does not converge on these data")
    return result


def explained_share(base: Model, model: Model, noise: GaugeNoise) -> float:
    """Share of the base misfit beyond the noise that ``model`` removes."""
    def excess(m: Model) -> float:
        return max(m.rss / noise.variance - m.verdict.dof, 0.0)

    before = excess(base)
    return 1.0 if before <= 0 else float(np.clip(1.0 - excess(model) / before, 0.0, 1.0))


def diagnose(obs: Observations, *, alpha: float = LEVEL, separate: bool = True,
             maps: bool = True, pitch_band_mm: tuple[float, float] | None = None,
             ) -> Diagnosis:
    """Diagnose ``obs`` (raw readings or tabulated deviations). ``separate``: also
    search the plans that would tell aliased effects apart; ``maps``: also search
    errors along each axis and in time beyond the library (raw readings);
    ``pitch_band_mm``: the periods a designed scan's positions sample (the cyclic
    error is searched there; None: from the positions' spacing)."""
    noise = noise_for(obs)
    problem = Problem(obs, noise)
    base_fit = _refit(obs, BASE_MODEL, noise)
    # a side unknown before a joint's first recorded move, resolved where its lost
    # motion decides it (the joint offsets' fit is the same either way)
    obs, problem, sides = resolve_sides(obs, noise, problem, base_fit.theta)
    base = evaluate(problem, noise, (), base_fit.theta, base_fit.identifiability.rank, alpha,
                    _fit_jacobian(base_fit, obs, BASE_MODEL))
    # model-free, before any effect is tried: a slip of one reading is no physics
    outliers = find_outliers(obs, problem.labels, noise, alpha, BASE_MODEL)

    everything = BASE_MODEL + EFFECT_PARAMETERS
    design = Design(everything, problem.jacobian(base.theta, everything))
    # From the Jacobian's R factor: the same inner products as the Jacobian itself,
    # every effect's column (30 rows instead of one per reading).
    seen = capability(design.factors[1], everything, noise.sigma_mm, problem.n_data)
    located = locate(obs, base.residuals, _unweighted_jacobian(problem, base),
                     noise.sigma_mm, problem.labels)

    selection = select(problem, noise, base, alpha=alpha, design=design)
    share = explained_share(base, selection.final, noise)
    claimed, final_fit = base, base_fit
    if selection.final.effects and (selection.final.verdict.consistent
                                    or share >= PARTIAL_SHARE):
        final_fit = _refit(obs, selection.final.names, noise, selection.final.theta)
        claimed = evaluate(problem, noise, selection.final.effects, final_fit.theta,
                           final_fit.identifiability.rank, alpha,
                           _fit_jacobian(final_fit, obs, selection.final.names))
    remaining = located if claimed is base else locate(
        obs, claimed.residuals, _unweighted_jacobian(problem, claimed), noise.sigma_mm,
        problem.labels)

    inflation = claimed.verdict.inflation
    effects = _effects(obs, problem, noise, claimed, final_fit, inflation, separate)
    cell = resting_cell(problem, noise, base, claimed, alpha)
    for effect in effects:
        effect.local_disturbance = cell
    plans = []
    if separate and not base.verdict.consistent and (
            seen.invisible() or seen.alias_groups() or seen.saturated):
        plans = plan_capabilities(obs.machine, claimed.theta, noise.sigma_mm)
    mapped = map_diagnosis(problem, noise, claimed, alpha, separate, base,
                           pitch_band_mm=pitch_band_mm) if maps and obs.raw else None
    all_effects: list[EffectFound | MapEffect] = list(effects)
    final_residuals = claimed.residuals
    if mapped is not None:
        for effect in effects:  # library effects a map explains as well
            effect.alternatives = effect.alternatives + \
                mapped.library_alternatives.get(effect.name, [])
    if mapped is not None and mapped.fit is not None:
        fitted = mapped.fit
        final_fit = as_fit_result(fitted, final_fit)
        final_residuals = fitted.residuals
        inflation = fitted.verdict.inflation
        dropped = {name for name, _ in mapped.dropped}
        kept = [e for e in effects if e.name not in dropped]
        for effect in kept:  # their values beside the maps
            effect.value = final_fit.value(effect.name)
            effect.std = float(np.hypot(fitted.std(effect.name) * inflation,
                                        effect.model_spread))
        all_effects = [*kept, *mapped.effects]
        remaining = locate(obs, fitted.residuals, fitted.jacobian, noise.sigma_mm,
                           problem.labels)
        share = explained_share(base, Model(claimed.effects, fitted.theta, fitted.residuals,
                                            fitted.rss, fitted.rank, fitted.verdict), noise)
    profiles = leg_profiles(obs, base.residuals, final_residuals)
    return Diagnosis(obs.source, obs.kind, len(obs), noise, seen, selection, claimed, share,
                     base_fit, final_fit, located, remaining, all_effects, inflation,
                     _postures_per_leg(problem), plans, mapped, profiles, sides, outliers)


def _fit_jacobian(result: FitResult, obs: Observations, names: tuple[str, ...],
                  ) -> np.ndarray | None:
    """The unweighted Jacobian of ``names`` at the fit's solution on ``obs``: the one
    its last step evaluated (``identify.fit``: the same call at the same point), when
    it fitted these very observations (not those before their sides were resolved)
    and these names in this order; else None."""
    if result.observations is not obs or result.names != names or result.method != "exact":
        return None
    return result.jacobian


def _unweighted_jacobian(problem: Problem, model: Model) -> np.ndarray:
    """The model's unweighted Jacobian at its solution: the one its verdict was judged
    with, else evaluated now."""
    if model.jacobian is not None:
        return model.jacobian
    return problem.jacobian(model.theta, model.names, False)


def _postures_per_leg(problem: Problem) -> int:
    if not problem.obs.raw:
        return 3  # tabulated deviations: Zero, Max, Min
    labels = problem.labels
    return max(len(set(labels.posture[labels.leg == leg].tolist()))
               for leg in set(labels.leg.tolist()))


def _effects(obs: Observations, problem: Problem, noise: GaugeNoise, final: Model,
             final_fit: FitResult, inflation: float, separate: bool) -> list[EffectFound]:
    if not final.effects:
        return []
    swaps = alternatives(problem, noise, final)
    signatures = None
    if separate and any(swaps.values()):
        names = tuple(dict.fromkeys(final.names + tuple(
            a.name for alts in swaps.values() for a in alts[:SEPARATED_ALTERNATIVES])))
        signatures = PlanSignatures(obs.machine, final.theta, names, problem)
    found = []
    for name in final.effects:
        value = final_fit.value(name)
        noise_std = float(final_fit.std[final_fit.names.index(name)]) * inflation
        # When another effect of the model could be swapped for an alternative, this
        # effect's value depends on that unresolved choice: widen its std by the
        # spread of its value over those equally good models.
        spread = max((abs(a.theta[PARAM_INDEX[name]] - value)
                      for other, alts in swaps.items() if other != name for a in alts),
                     default=0.0)
        seps = [] if signatures is None else [
            separation(signatures, final.names, name, value, a.name, a.value, noise.sigma_mm)
            for a in swaps[name][:SEPARATED_ALTERNATIVES]]
        found.append(EffectFound(name, value, float(np.hypot(noise_std, spread)),
                                 swaps[name], seps, model_spread=spread))
    # Most important first: the effect best determined relative to its std.
    return sorted(found, key=lambda e: -abs(e.value) / e.std if e.std > 0 else 0.0)
