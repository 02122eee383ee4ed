"""The record's uncertainty and conformity: the GUM budget of each identified
parameter, its Monte-Carlo check, and the acceptance of the leg-parallelism
deviations as found and as left (ogacq.uncertainty, docs/calibration-record.md
sections 3-4), from what the session recorded.

The inputs are the session's own: the gauges' certificates (U / k), the
temperatures at start and end, the machine file's expansion coefficient and
tolerances. What the session does not hold is passed as unknown, so the budget
lists that source as "not evaluated" and says it is incomplete; nothing is
assumed in its place.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from ogacq.identify.fit import FitResult
from ogacq.model.machine import MachineSpec
from ogacq.record.context import CalibrationContext
from ogacq.uncertainty.acceptance import (
    Acceptance,
    acceptance_json,
    evaluate_acceptance,
    tolerances_for,
)
from ogacq.uncertainty.budget import Budget, deviation_budget, uncertainty_budget
from ogacq.uncertainty.inputs import BudgetInputs
from ogacq.uncertainty.montecarlo import monte_carlo

# GUM S1 (JCGM 101:2008 7.2) asks for enough draws for the quantity checked; the
# check here is a standard deviation within 10 %, whose own relative standard error
# with 2000 draws is about 1.6 % for normal outputs: a fixed seed makes the record
# reproducible.
MC_DRAWS = 2000
MC_SEED = 0


@dataclass
class Evaluation:
    """What the record shows of the uncertainty, and why a part is missing."""

    results: dict[str, dict[str, dict[str, Any]]] | None = None
    budget: dict[str, list[dict[str, Any]]] | None = None
    budget_complete: bool = False
    monte_carlo: dict[str, Any] | None = None
    acceptance: dict[str, Any] = field(default_factory=dict)
    missing: dict[str, str] = field(default_factory=dict)
    # the validation campaign's parameters (what remains after the write-back), each
    # with its u and U from its own budget, shaped as ``results``
    validation_results: dict[str, dict[str, dict[str, Any]]] | None = None


def budget_inputs(result: FitResult, context: CalibrationContext) -> BudgetInputs:
    """The budget's inputs from the fit (noise, resolution, leg length) and the
    session's context (certificates, temperatures, the legs' expansion)."""
    machine = result.observations.machine
    environment = context.environment
    given: dict[str, Any] = {
        "calibration_u_mm": {i.gauge: i.standard_uncertainty_mm for i in context.instruments
                             if i.gauge},
        "ambient_start_c": environment.start.ambient_c if environment.start else None,
        "ambient_end_c": environment.end.ambient_c if environment.end else None}
    if machine.leg_expansion_ppm_per_k is not None:
        given["leg_expansion_ppm_per_k"] = machine.leg_expansion_ppm_per_k
    return BudgetInputs.from_fit(result, **given)


def evaluate(result: FitResult | None, context: CalibrationContext,
             validation: tuple[FitResult, CalibrationContext] | None = None,
             validation_problem: str | None = None, *,
             machine: MachineSpec | None = None) -> Evaluation:
    """The budget, Monte-Carlo check and acceptance of a campaign's fit ``result``;
    ``validation``: the as-left campaign's fit and context, when one was run;
    ``machine``: the session's machine (its tolerances), default the fit's."""
    out = Evaluation()
    if machine is None and result is not None:
        machine = result.observations.machine
    if result is None:
        out.missing["uncertainty"] = "not evaluated: nothing was identified"
        out.acceptance = _acceptance(machine, None, None, "nothing was identified",
                                     validation_problem)
        return out
    try:
        inputs = budget_inputs(result, context)
        budget = uncertainty_budget(result.observations, result, inputs)
    except ValueError as exc:
        out.missing["uncertainty"] = f"not evaluated: {exc}"
        out.acceptance = _acceptance(machine, None, None, f"no uncertainty ({exc})",
                                     validation_problem)
        return out
    parameters = budget.to_json()
    out.results, out.budget = parameters["results"], parameters["budget"]
    out.budget_complete = bool(parameters["budget_complete"])
    if not out.budget_complete:
        out.missing["uncertainty budget"] = incomplete(budget)
    try:
        out.monte_carlo = monte_carlo(result.observations, result, inputs, draws=MC_DRAWS,
                                      seed=MC_SEED, budget=budget).to_json()
    except (ValueError, ArithmeticError) as exc:
        out.missing["monte_carlo"] = f"not evaluated: {exc}"

    found, why_found = None, None
    try:  # a scan has no Zero/Max/Min deviations to accept
        found = deviation_budget(result.observations, inputs)
    except ValueError as exc:
        why_found = f"no deviations to judge: {exc}"
    left = None
    if validation is not None:
        v_result, v_context = validation
        try:
            v_inputs = budget_inputs(v_result, v_context)
            left = deviation_budget(v_result.observations, v_inputs)
            out.validation_results = uncertainty_budget(
                v_result.observations, v_result, v_inputs).to_json()["results"]
        except ValueError as exc:
            validation_problem = f"the as-left deviations have no uncertainty ({exc})"
    out.acceptance = _acceptance(machine, found, left, why_found, validation_problem)
    return out


def incomplete(budget: Budget) -> str:
    """Which sources were not evaluated, for which parameters: the record's reason
    for an incomplete budget."""
    parts = [f"{o.name}: {', '.join(o.not_evaluated) or o.note or 'not determined'}"
             for o in budget.outputs if not o.complete]
    return "incomplete, not evaluated: " + "; ".join(parts)


def _acceptance(machine: MachineSpec | None, found: Budget | None, left: Budget | None,
                why_found: str | None, why_left: str | None) -> dict[str, Any]:
    """As found and as left against the machine file's tolerances (section 4)."""
    tolerances = machine.tolerances if machine is not None else None
    if tolerances is None:
        why = "the machine file states no tolerances"
        if left is None:
            why_left = why_left or "no as-left measurement"
        return {"rule": None,
                "as_found": {"decision": "not evaluated", "rule": None, "rows": [], "why": why},
                "as_left": {"decision": "not evaluated", "rule": None, "rows": [],
                            "why": why_left or why}}
    rule = tolerances.decision_rule

    def stage(budget: Budget | None, name: str, why: str | None) -> Acceptance:
        if budget is None:
            return evaluate_acceptance(None, {}, rule, name, why_absent=why or "")
        limits = tolerances_for(list(budget.names), tolerances.default_mm, tolerances.per_deviation)
        return evaluate_acceptance(budget.for_acceptance(), limits, rule, name)

    return acceptance_json(stage(found, "as-found", why_found),
                           stage(left, "as-left", why_left or "no as-left measurement"))
