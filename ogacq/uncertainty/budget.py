"""The uncertainty budget of each identified parameter and each leg-parallelism
deviation (JCGM 100:2008, the GUM).

Every source (``sources.py``) is carried to the outputs by one linear operator:
for the parameters, the fit's own weighted least-squares solution operator at its
solution (the sensitivity of the parameters to the observations, JCGM 100:2008
5.1.3: ``c_i = df/dx_i``, evaluated by the fit's linearisation, not guessed); for
the deviations, the averaging that forms them from the readings. Contributions
``u_i = |c_i| u(x_i)`` (5.1.3) combine by the root sum of squares (5.1.2, the
sources being independent of each other), ``U = k u_c`` with ``k = 2`` (6.2.1,
6.3.3), the effective degrees of freedom by Welch-Satterthwaite (G.4.1, eq. G.2b).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ogacq.identify.fit import FitResult, Weighting
from ogacq.identify.identifiability import plausible_ranges
from ogacq.identify.observations import Observations, deviation_readings
from ogacq.model.parameters import NOMINAL, nested
from ogacq.uncertainty.acceptance import Measured, json_mm
from ogacq.uncertainty.inputs import BudgetInputs
from ogacq.uncertainty.sources import (
    ObservationSpace,
    Source,
    display_resolution,
    gauge_calibrations,
    gauge_noise,
    mean_temperature_offset,
    register_rounding,
    temperature,
)

COVERAGE_FACTOR = 2.0  # JCGM 100:2008 6.3.3: k = 2 gives about 95 % for a normal u_c


@dataclass(frozen=True)
class BudgetRow:
    source: str
    gum_type: str  # "A" or "B"
    distribution: str  # "normal" or "rectangular"
    u_input: float | None  # the input's standard uncertainty, in ``unit``
    unit: str
    sensitivity: float  # c_i: output mm per unit of input (5.1.3)
    u_mm: float | None  # |c_i| u(x_i); None when not evaluated
    dof: float  # math.inf for a type B input
    evaluated: bool
    note: str = ""

    def to_json(self) -> dict:
        return {"source": self.source, "type": self.gum_type,
                "distribution": self.distribution, "u_input": json_mm(self.u_input),
                "unit": self.unit, "sensitivity": json_mm(self.sensitivity),
                "u_mm": json_mm(self.u_mm), "dof": _dof(self.dof),
                "evaluated": self.evaluated, "note": self.note}


@dataclass(frozen=True)
class OutputBudget:
    """The budget of one output: an identified parameter or a deviation."""

    name: str
    value_mm: float
    rows: tuple[BudgetRow, ...]
    u_c: float  # from the evaluated rows; math.inf when the data do not determine it
    k: float
    dof_eff: float
    # Add this to refer the value to 20 degC (the mean temperature's known
    # systematic effect, JCGM 100:2008 3.2.4); None when the temperature is unknown.
    temperature_correction_mm: float | None
    determined: bool = True  # False: the data do not determine it at all (rank deficient)
    # False: determined only in combination with another parameter (|correlation| >
    # 0.99) or beyond its plausible range: u_c is the estimator's spread, but the value
    # is not a calibration of this parameter alone
    identified: bool = True
    note: str = ""

    @property
    def U(self) -> float:  # noqa: N802 - the GUM's name for the expanded uncertainty
        return self.k * self.u_c

    @property
    def complete(self) -> bool:
        return self.determined and self.identified and all(row.evaluated for row in self.rows)

    @property
    def not_evaluated(self) -> list[str]:
        return [row.source for row in self.rows if not row.evaluated]

    def result_json(self) -> dict:
        finite = self.determined and math.isfinite(self.u_c)
        return {"value_mm": json_mm(self.value_mm),
                "u_mm": json_mm(self.u_c) if finite else None,
                "U_mm": json_mm(self.U) if finite else None, "k": self.k,
                "dof_eff": _dof(self.dof_eff), "complete": self.complete,
                "identified": self.determined and self.identified,
                "temperature_correction_mm": json_mm(self.temperature_correction_mm),
                "note": self.note}


@dataclass(frozen=True)
class Budget:
    """Budgets of several outputs; ``kind`` "parameters" (names like
    ``joint_offset.x``) or "deviations" (``dx_y+``)."""

    kind: str
    outputs: tuple[OutputBudget, ...]

    @property
    def complete(self) -> bool:
        return all(o.complete for o in self.outputs)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(o.name for o in self.outputs)

    def __getitem__(self, name: str) -> OutputBudget:
        for output in self.outputs:
            if output.name == name:
                return output
        raise KeyError(f"no budget for {name!r}; there are {', '.join(self.names)}")

    def to_json(self) -> dict:
        """The record's ``results``, ``budget`` and ``budget_complete`` (parameters), or
        ``deviations``, ``budget`` and ``budget_complete`` (deviations)."""
        results = [o.result_json() for o in self.outputs]
        key = "results" if self.kind == "parameters" else "deviations"
        return {key: nested(self.names, results) if self.kind == "parameters"
                else dict(zip(self.names, results, strict=True)),
                "budget": {o.name: [row.to_json() for row in o.rows] for o in self.outputs},
                "budget_complete": self.complete}

    def for_acceptance(self) -> dict[str, Measured]:
        """Each output's value and U for the acceptance; no U where the budget is
        incomplete (an underestimated U would shrink the guard band: ILAC-G8:09/2019
        section 4.2.2 needs the full expanded uncertainty)."""
        out = {}
        for o in self.outputs:
            if o.complete:
                out[o.name] = Measured(o.value_mm, o.U)
            else:
                missing = ", ".join(o.not_evaluated) or o.note
                out[o.name] = Measured(o.value_mm, None,
                                       f"uncertainty budget incomplete ({missing})")
        return out


def solution_operator(result: FitResult) -> np.ndarray:
    """(p, m) how the fitted parameters move per unit change of each observation: the
    fit's weighted least-squares solution at its solution, truncated to the directions
    the data determine exactly as the fit's own steps are (``fit._solve``)."""
    obs = result.observations
    weighting = Weighting(obs, result.weighting, result.noise)
    m = len(obs)
    # (P W): whitening and removal of the gauge zeros, as a matrix on the observations
    whiten = weighting.residual(np.eye(m)).T
    jw = weighting.jac(result.jacobian[None])[0]
    ranges = plausible_ranges(result.names)
    u, s, vt = np.linalg.svd(jw * ranges, full_matrices=False)
    rank = result.identifiability.rank
    solve = (vt[:rank].T * ranges[:, None]) @ (u[:, :rank] / s[:rank]).T
    return solve @ whiten


def _sources(obs: Observations, theta: np.ndarray, inputs: BudgetInputs) -> list[Source]:
    return [gauge_noise(inputs), display_resolution(obs, inputs),
            *gauge_calibrations(obs, inputs), *temperature(obs, theta, inputs)]


def _budgets(names: Sequence[str], values: np.ndarray, operator: np.ndarray,
             space: ObservationSpace, sources: Sequence[Source], inputs: BudgetInputs,
             determined: np.ndarray, unidentified: Sequence[str] = (),
             why_unidentified: str = "") -> tuple[OutputBudget, ...]:
    """Each output's rows: every source's sensitivity through ``operator`` (q, m)."""
    sensitivities = [_sensitivity(source, names, operator, space) for source in sources]
    offset = mean_temperature_offset(inputs)
    thermal = next((k for k, s in enumerate(sources) if s.name == "temperature range"), None)
    out = []
    for q, name in enumerate(names):
        rows = _rows(name, q, sources, sensitivities)
        contributions = [(r.u_mm, r.dof) for r in rows if r.u_mm is not None]
        u_c = math.sqrt(sum(u**2 for u, _ in contributions))
        correction = None if offset is None or thermal is None else \
            float(sensitivities[thermal][q]) * offset
        note = "" if name not in unidentified else \
            f"not identified from these data: {why_unidentified}"
        if not determined[q]:
            note = "not determined by these data (rank deficient): " + why_unidentified
        out.append(OutputBudget(name, float(values[q]), tuple(rows),
                                u_c if determined[q] else math.inf, COVERAGE_FACTOR,
                                welch_satterthwaite(u_c, contributions), correction,
                                bool(determined[q]), name not in unidentified, note))
    return tuple(out)


def _sensitivity(source: Source, names: Sequence[str], operator: np.ndarray,
                 space: ObservationSpace) -> np.ndarray:
    """How much each output moves per unit of the source: through the readings it
    spreads over, through its own vector of them, or (a direct one) 1 on each offset."""
    if source.readings:
        return space.reading_spread(operator, source.shared)
    if source.vector is not None:
        return operator @ source.vector
    return np.array([1.0 if n.startswith("joint_offset.") else 0.0 for n in names])


def _rows(name: str, q: int, sources: Sequence[Source],
          sensitivities: Sequence[np.ndarray]) -> list[BudgetRow]:
    """Output ``q``'s row of each source that acts on it."""
    rows = []
    for source, c in zip(sources, sensitivities, strict=True):
        if source.direct and not name.startswith("joint_offset."):
            continue  # only offsets are written to the controller's registers
        u = None if source.u_input is None else abs(float(c[q])) * source.u_input
        rows.append(BudgetRow(source.name, source.gum_type, source.distribution,
                              source.u_input, source.unit, float(c[q]), u, source.dof,
                              source.evaluated, source.note))
    return rows


def uncertainty_budget(obs: Observations, result: FitResult, inputs: BudgetInputs) -> Budget:
    """The budget of every parameter ``result`` identified from ``obs``."""
    if len(result.observations) != len(obs) or result.jacobian.shape[0] != len(obs):
        raise ValueError(f"the fit result was computed from {len(result.observations)} "
                         f"observations, these are {len(obs)}")
    operator = solution_operator(result)
    space = ObservationSpace(obs)
    sources = _sources(obs, result.theta, inputs)
    rounding = register_rounding(inputs)
    if rounding is not None:
        sources.append(rounding)
    determined = np.isfinite(result.std)
    ident = result.identifiability
    return Budget("parameters", _budgets(result.names, result.values, operator, space,
                                         sources, inputs, determined, ident.unidentified,
                                         "; ".join(ident.reasons)))


def deviations_operator(obs: Observations) -> tuple[list[str], np.ndarray]:
    """The twelve-form deviations ``dX_Y+``/``dX_Y-`` and the (d, m) averaging that
    forms them from the observations: each posture's readings averaged over the
    cycles, Max (Min) minus Zero, as ``averaged_deviations`` does; tabulated
    deviations are their own (the identity)."""
    if not obs.raw:
        return list(obs.labels), np.eye(len(obs))
    formed = deviation_readings(obs)
    return [name for name, _, _ in formed], np.array(
        [of / of.sum() - base / base.sum() for _, of, base in formed], dtype=float)


def deviation_budget(obs: Observations, inputs: BudgetInputs) -> Budget:
    """The leg-parallelism deviations (INTERCHANGE "Deviations CSV" names) with their
    budgets from the same inputs; the thermal sensitivities at the nominal machine."""
    names, operator = deviations_operator(obs)
    values = operator @ obs.values
    sources = _sources(obs, NOMINAL.copy(), inputs)
    return Budget("deviations", _budgets(names, values, operator, ObservationSpace(obs),
                                         sources, inputs, np.ones(len(names), dtype=bool)))


def welch_satterthwaite(u_c: float, contributions: Sequence[tuple[float, float]]) -> float:
    """``nu_eff = u_c^4 / sum(u_i^4 / nu_i)`` (JCGM 100:2008 G.4.1, eq. G.2b); infinite
    when every contribution has infinite degrees of freedom (type B, G.4.3)."""
    denominator = sum(u**4 / dof for u, dof in contributions if math.isfinite(dof) and u > 0)
    return math.inf if denominator == 0 else u_c**4 / denominator


def _dof(value: float) -> float | None:
    """JSON has no infinity: null stands for infinite degrees of freedom."""
    return None if not math.isfinite(value) else round(float(value), 2)

