"""The validation campaign judged against the campaign the compensation came from.

After the write, the same plan is run again. Its readings are fitted with the
joint offsets and the effects no table corrects (a squareness stays until the
machine is adjusted): with the compensation right, that fit is within the gauge
noise, the joint offsets near zero, and the corrected effects gone. Worse than
before, and restored, when any of these holds (each with its reason):

* the validation fit is not within the noise and its misfit per degree of freedom
  is larger than the same model's on the campaign before (the write added error);
* a joint offset left is larger than the one the write corrected, by more than
  three combined standard deviations (a wrong sign, a wrong value);
* an axis's systematic positioning error E (ISO 230-2) after, from the corrected
  effects identified again and what the maps left (``_after_maps``), exceeds the one
  before by more than three combined uncertainties of the maps.

Otherwise it is ``validated`` when the fit is within the noise and its test would
have seen every correction go wrong, ``not shown`` when the fit is within the noise
but an error of a correction's size would pass the test somewhere along its axis
(``ogacq.calibration.sight``: where it sees, its limit elsewhere, what would show it),
and ``improved`` (kept, not within the noise) when the fit is not within the noise
but nothing got worse.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace
from enum import StrEnum
from typing import Any

import numpy as np

from ogacq.calibration.compensate import Compensation
from ogacq.calibration.drive_step import with_drive_step
from ogacq.calibration.maps import diagnosis_maps
from ogacq.calibration.scale_check import ScaleCheck
from ogacq.calibration.sight import AxisSight, largest_correction, merged, sights
from ogacq.compensation.combine import compensation
from ogacq.compensation.effects import EffectValue, effect_maps
from ogacq.compensation.iso230 import map_figures
from ogacq.diagnose.diagnosis import diagnose
from ogacq.diagnose.maps import maps_left
from ogacq.identify.consistency import LEVEL, Verdict, fit_verdict
from ogacq.identify.distributions import f_sf
from ogacq.identify.fit import FitResult, fit
from ogacq.identify.noise import noise_for
from ogacq.identify.observations import Observations
from ogacq.model.axis_map import AxisMap
from ogacq.model.error_maps import terms_of
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import AXES, PARAM_SETS
from ogacq.model.units import UM_PER_MM
from ogacq.protocol.plan import ProtocolConfig, reading_steps
from ogacq.protocol.scan_design import sampled_band
from ogacq.session.convert import session_observations
from ogacq.session.store import LoadedSession

SIGMAS = 3.0  # how far beyond the combined uncertainty "worse" starts


class Outcome(StrEnum):
    """A validation's outcome, from the worst to the best (the words of calibrate's
    end: ``WriteOutcome``)."""

    WORSE = "worse"
    IMPROVED = "improved"  # kept, not within the noise
    NOT_SHOWN = "not shown"  # within the noise, a correction not seen along its axis
    VALIDATED = "validated"


@dataclass(frozen=True)
class Judgement:
    outcome: Outcome
    reasons: tuple[str, ...]  # why worse (empty otherwise)
    verdict: dict[str, Any]  # of the validation fit
    chi2_dof_before: float
    chi2_dof_after: float
    offsets_before_mm: dict[str, float]
    offsets_after_mm: dict[str, float]
    offsets_after_std_mm: dict[str, float]
    figures_before: dict[str, dict[str, Any]]
    figures_after: dict[str, dict[str, Any]]
    residual_effects: dict[str, dict[str, float]] = field(default_factory=dict)
    looked: str = ""  # where the validation read, and that between those it did not
    sight: dict[str, AxisSight] = field(default_factory=dict)  # how far it sees each map
    # each scaled axis's positioning tests before and after (ogacq.calibration.scale_check)
    scales: dict[str, ScaleCheck] = field(default_factory=dict)

    @property
    def worse(self) -> bool:
        return self.outcome == Outcome.WORSE

    def merged(self, other: Judgement) -> Judgement:
        """Two validations of one write (the calibration plan, a scan): worse when either
        is, within the noise when both are, and then a correction shown where either
        sees it; the figures of the scan where it has them."""
        outcome = min(self.outcome, other.outcome, key=list(Outcome).index)
        sight = merged(self.sight, other.sight)
        outcome = outcome_of(outcome == Outcome.WORSE, outcome != Outcome.IMPROVED, sight)
        # the verdict said is the one that decides: a fit not within the noise is not
        # described by the other's "within the gauge noise"
        verdict = other.verdict if other.outcome == Outcome.IMPROVED != self.outcome \
            else self.verdict
        return replace(self, outcome=outcome, reasons=self.reasons + other.reasons,
                       verdict=verdict,
                       figures_after={**self.figures_after, **other.figures_after},
                       residual_effects={**self.residual_effects, **other.residual_effects},
                       sight=sight)

    def seen(self) -> list[str]:
        """What the validation shows of each correction, in words: where it would see
        one of its size go wrong, and its limit elsewhere."""
        return [s.sentence() for s in self.sight.values()]

    def to_json(self) -> dict[str, Any]:
        """Every field in its order, the scales only where a scale checked an axis."""
        out = {f.name: getattr(self, f.name) for f in fields(self)}
        out.update(outcome=str(self.outcome), reasons=list(self.reasons),
                   chi2_dof_before=_num(self.chi2_dof_before),
                   chi2_dof_after=_num(self.chi2_dof_after),
                   sight={a: s.to_json() for a, s in self.sight.items()},
                   scales={a: c.to_json() for a, c in self.scales.items()})
        return out if self.scales else {k: v for k, v in out.items() if k != "scales"}

    def with_scales(self, checks: dict[str, ScaleCheck], maps: dict[str, AxisMap],
                    machine: MachineSpec) -> Judgement:
        """This judgement with what each axis's scale found of its map: worse where the
        scale finds E or A grown, the axis's sight the scale's (whole travel) instead of
        the legs'."""
        if not checks:
            return self
        lo, hi = machine.rho_min_mm, machine.rho_max_mm
        sight = dict(self.sight)
        for axis, check in checks.items():
            sight[axis] = check.sight(largest_correction(maps[axis], lo, hi), machine)
        reasons = self.reasons + tuple(c.worse for c in checks.values() if c.worse)
        outcome = outcome_of(bool(reasons),
                             self.outcome in (Outcome.VALIDATED, Outcome.NOT_SHOWN), sight)
        return replace(self, outcome=outcome, reasons=reasons, sight=sight,
                       scales={**self.scales, **checks})


def outcome_of(worse: bool, within_noise: bool, sight: dict[str, AxisSight]) -> Outcome:
    """A validation's outcome: worse (with reasons), else improved when its fit is not
    within the noise, else validated when its test sees every correction go wrong
    (``sight``) and not shown when it does not."""
    if worse:
        return Outcome.WORSE
    if not within_noise:
        return Outcome.IMPROVED
    return Outcome.VALIDATED if all(s.shown for s in sight.values()) else Outcome.NOT_SHOWN


def where_looked(sessions: list[LoadedSession], machine: MachineSpec) -> str:
    """Where the validation campaigns read each leg, in words: "at N positions of each
    leg's travel (...); between them not measured"."""
    parts, total = [], set()
    for session in sessions:
        plan = session.header.plan
        if plan is None:
            continue
        reads = reading_steps(ProtocolConfig.from_dict(dict(plan)), machine)
        own = {(r.leg, round(r.q_mm[AXES.index(r.leg)], 6)) for r in reads}
        total |= own
        legs = {r.leg for r in reads}
        parts.append(f"{len(own) // max(len(legs), 1)} in {session.path.stem}")
    legs_read = {leg for leg, _ in total}
    per_leg = len(total) // max(len(legs_read), 1)
    return (f"at {per_leg} positions of each leg's travel ({', '.join(parts)}); "
            "between them not measured")


def _num(x: float) -> float | None:
    return round(float(x), 6) if math.isfinite(x) else None


def validation_fit(obs: Observations, names: tuple[str, ...]) -> tuple[FitResult, Verdict]:
    """``names`` fitted to ``obs`` as a validation fits them (GLS), and its verdict."""
    result = fit(obs, names, method="exact", weighting="gls", noise=noise_for(obs))
    return result, fit_verdict(result)


def judge(comp: Compensation, before: LoadedSession, after: LoadedSession,
          machine: MachineSpec, resolution_mm: float = 0.0,
          drive_step_mm: float = 0.0) -> Judgement:
    """``resolution_mm``: the step the controller stores offsets with (what a written
    offset may be off by, on top of the identification's std); ``drive_step_mm``: the
    drives' position step, which every figure after carries beside it
    (``ogacq.calibration.drive_step``)."""
    stay = tuple(comp.uncompensated)
    base = PARAM_SETS["offsets"] + stay
    _, v_before = validation_fit(session_observations(before), base)
    obs_after = session_observations(after)
    result, v_after = validation_fit(obs_after, base)
    drho = {a: result.value(f"joint_offset.{a}") for a in AXES}
    drho_std = {a: float(result.std[result.names.index(f"joint_offset.{a}")]) for a in AXES}
    reasons = []
    if not v_after.consistent and misfit_grew(v_before, v_after):
        reasons.append(f"the validation fit is not within the noise and its misfit per dof "
                       f"grew from {v_before.chi2_dof:.3g} to {v_after.chi2_dof:.3g}")
    for a in AXES:
        was, now = abs(comp.offsets_mm[a]), abs(drho[a])
        margin = SIGMAS * math.hypot(comp.offsets_std_mm.get(a, 0.0), drho_std[a],
                                     resolution_mm / math.sqrt(12))
        if now > was + margin:
            reasons.append(f"the joint offset of {a} left ({drho[a]:+.4f} mm) is larger than "
                           f"the one corrected ({comp.offsets_mm[a]:+.4f} mm)")
    plan = after.header.plan
    band = sampled_band(ProtocolConfig.from_dict(dict(plan)), machine) if plan else None
    figures_after, residual = _after_maps(comp, obs_after, base, machine, band)
    if drive_step_mm:
        figures_after = with_drive_step(figures_after, drive_step_mm)
    figures_before = comp.figures_before()
    for a, fig in figures_after.items():
        if a not in figures_before:
            continue
        was, now = figures_before[a]["E_mm"], fig["E_mm"]
        u = max(max(comp.maps[a].u_forward_mm), max(comp.maps[a].u_reverse_mm))
        margin = SIGMAS * math.hypot(u, fig.get("u_max_mm", 0.0))
        if now > was + margin:
            reasons.append(f"axis {a}: systematic positioning error E grew from "
                           f"{was * UM_PER_MM:.1f} to {now * UM_PER_MM:.1f} µm (ISO 230-2)")
    sight = sights(comp.maps, result, v_after, machine) if v_after.consistent else {}
    outcome = outcome_of(bool(reasons), v_after.consistent, sight)
    p_value = v_after.p_value if math.isfinite(v_after.p_value) else None
    return Judgement(outcome, tuple(reasons), {**v_after.to_json(), "text": v_after.describe(),
                                               "state": v_after.state, "p_value": p_value},
                     v_before.chi2_dof, v_after.chi2_dof, dict(comp.offsets_mm), drho, drho_std,
                     figures_before, figures_after, residual, sight=sight)


def misfit_grew(before: Verdict, after: Verdict) -> bool:
    """The validation's misfit per dof beyond the calibration campaign's by more than
    chance: under a correction that changed nothing the ratio of the two is an F of
    their degrees of freedom, and it must pass that F's 1 - ``LEVEL`` quantile (no
    source: a choice, the verdict's own level). "Merely larger" is met half the time
    when both are near 1 per dof, so a validation not within the noise by chance (its
    worst cell alone, once in a hundred) restored a machine put right: the demo's
    squareness run, once under load in the CI command, where alone it is validated."""
    if not (math.isfinite(after.chi2_dof) and math.isfinite(before.chi2_dof)) \
            or before.chi2_dof <= 0 or before.dof <= 0 or after.dof <= 0:
        return after.chi2_dof > before.chi2_dof
    ratio = after.chi2_dof / before.chi2_dof
    return float(f_sf(after.dof, before.dof, ratio)) < LEVEL


def _after_maps(comp: Compensation, obs: Observations, base: tuple[str, ...],
                machine: MachineSpec, band: tuple[float, float] | None = None,
                ) -> tuple[dict[str, dict[str, Any]], dict[str, dict[str, float]]]:
    """The ISO 230-2 figures of each compensated axis after: the corrected library
    effects identified again on the validation, and what the maps left: the maps its
    diagnosis finds, else, on an axis it read densely, the written maps' own terms
    fitted again (what is left of them, with its band: a correction that worked leaves
    figures within that band, not none). An axis the validation cannot map has none."""
    names = base + tuple(comp.compensated)
    result, _ = validation_fit(obs, names)
    values = {n: EffectValue(n, result.value(n), float(result.std[result.names.index(n)]))
              for n in comp.compensated}
    found: tuple[AxisMap, ...] = ()
    if comp.diagnosis_maps:  # maps left are the validation's diagnosis's to find
        diagnosis = diagnose(obs, pitch_band_mm=band)
        found = diagnosis_maps(diagnosis)
        seen = {m.axis for m in found}
        written = {AXES.index(a): (terms_of(m), (m.positions_mm[0], m.positions_mm[-1]),
                                   m.reference_mm)
                   for a, m in comp.maps.items() if a not in seen}
        coverage = diagnosis.mapped.search.coverage if diagnosis.mapped else ()
        found += maps_left(obs, names, result.theta, written, coverage)
    per_axis = compensation(found, effect_maps(values, machine), values)
    figures = {}
    for a, c in per_axis.items():
        fig = map_figures(c.axis_map).to_json()
        fig["u_max_mm"] = float(np.max([c.axis_map.u_forward_mm, c.axis_map.u_reverse_mm]))
        figures[a] = fig
    return figures, {n: {"value": v.value, "std": v.std} for n, v in values.items()}
