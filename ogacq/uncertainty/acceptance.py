"""Acceptance of the leg-parallelism deviations against their tolerances, with a
stated decision rule (docs/calibration-record.md section 4; ILAC-G8:09/2019):

- "guard-band": ``w = U`` (4.2.2, limit ``T - w``): pass when ``|d| <= T - U``, fail
  when ``|d| > T + U``, otherwise undecided (the non-binary statement of 4.2.3).
  Needs ``U``.
- "simple": ``w = 0`` (4.2.1): pass when ``|d| <= T``, fail otherwise.

A deviation without a tolerance (or without ``U`` under the guard band), or a
tolerance without its deviation, is "not evaluated" with the reason. Overall (no
source; the contract's rule): fail when any fails; pass only when every one passes;
else "not evaluated" when evidence is missing, else "undecided". Never a silent
pass."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import NamedTuple

RULES = ("guard-band", "simple")
STAGES = ("as-found", "as-left")
PASS, FAIL, UNDECIDED, NOT_EVALUATED = "pass", "fail", "undecided", "not evaluated"
# Comparisons at the limits allow this much for floating point (T - U is computed):
# a millionth of a micrometre, far below any gauge.
LIMIT_SLACK_MM = 1e-9


class Measured(NamedTuple):
    """A deviation's value and expanded uncertainty ``U`` (None: not known, and why)."""

    value_mm: float
    U_mm: float | None  # noqa: N815 - the GUM's name
    why_no_U: str = ""  # noqa: N815


@dataclass(frozen=True)
class Decision:
    deviation: str
    value_mm: float | None
    U_mm: float | None  # noqa: N815
    tolerance_mm: float | None
    decision: str
    why: str

    def to_json(self) -> dict:
        return {k: json_mm(v) if k.endswith("_mm") else v for k, v in asdict(self).items()}


@dataclass(frozen=True)
class Acceptance:
    stage: str  # "as-found" or "as-left"
    rule: str
    decision: str
    rows: tuple[Decision, ...]
    why: str = ""

    def to_json(self) -> dict:
        """One stage of the record's ``acceptance``: decision, rows, and why when not
        evaluated as a whole."""
        out: dict = {"decision": self.decision, "rule": self.rule,
                     "rows": [row.to_json() for row in self.rows]}
        if self.why:
            out["why"] = self.why
        return out


def evaluate_acceptance(deviations: Mapping[str, Measured | tuple] | None,
                        tolerances: Mapping[str, float | None], rule: str = "guard-band",
                        stage: str = "as-found", *, why_absent: str = "") -> Acceptance:
    """Decide each deviation (name -> (value, U)) against its tolerance (name -> T,
    None: no tolerance). ``deviations`` None: the stage was not measured."""
    if rule not in RULES:
        raise ValueError(f"decision rule must be one of {', '.join(RULES)}, got {rule!r}")
    if stage not in STAGES:
        raise ValueError(f"stage must be one of {', '.join(STAGES)}, got {stage!r}")
    for name, tolerance in tolerances.items():
        if tolerance is not None and not (math.isfinite(tolerance) and tolerance > 0):
            raise ValueError(f"tolerance of {name} must be a number > 0 mm, got {tolerance!r}")
    if deviations is None:
        why = why_absent or f"no {stage} measurement"
        return Acceptance(stage, rule, NOT_EVALUATED, (), why)
    rows = []
    for name, given in deviations.items():
        measured = Measured(*given)
        if not math.isfinite(measured.value_mm):
            raise ValueError(f"deviation {name} must be a finite number, got "
                             f"{measured.value_mm!r}")
        if measured.U_mm is not None and not (math.isfinite(measured.U_mm)
                                              and measured.U_mm >= 0):
            raise ValueError(f"U of deviation {name} must be a number >= 0 mm, got "
                             f"{measured.U_mm!r}")
        rows.append(_decide(name, measured, tolerances.get(name), rule))
    for name, tolerance in tolerances.items():
        if name not in deviations and tolerance is not None:
            rows.append(Decision(name, None, None, tolerance, NOT_EVALUATED, "not measured"))
    return Acceptance(stage, rule, overall([row.decision for row in rows]), tuple(rows),
                      "" if rows else "no deviation to judge")


def _decide(name: str, measured: Measured, tolerance: float | None, rule: str) -> Decision:
    d, U = measured.value_mm, measured.U_mm  # noqa: N806
    if tolerance is None:
        return Decision(name, d, U, None, NOT_EVALUATED, "no tolerance given")
    size = abs(d)
    if rule == "simple":
        ok = size <= tolerance + LIMIT_SLACK_MM
        return Decision(name, d, U, tolerance, PASS if ok else FAIL,
                        f"|d| {'<=' if ok else '>'} T (simple acceptance, ILAC-G8 4.2.1)")
    if U is None:
        return Decision(name, d, None, tolerance, NOT_EVALUATED,
                        measured.why_no_U or "no expanded uncertainty U")
    if size <= tolerance - U + LIMIT_SLACK_MM:
        return Decision(name, d, U, tolerance, PASS, "|d| <= T - U (guard band w = U)")
    if size > tolerance + U + LIMIT_SLACK_MM:
        return Decision(name, d, U, tolerance, FAIL, "|d| > T + U (guard band w = U)")
    return Decision(name, d, U, tolerance, UNDECIDED,
                    "T - U < |d| <= T + U: within the uncertainty of the limit")


def overall(decisions: list[str]) -> str:
    if not decisions:
        return NOT_EVALUATED
    if FAIL in decisions:
        return FAIL
    if all(d == PASS for d in decisions):
        return PASS
    return NOT_EVALUATED if NOT_EVALUATED in decisions else UNDECIDED


def tolerances_for(names: list[str], default_mm: float | None,
                   per_deviation: Mapping[str, float] | None = None) -> dict[str, float | None]:
    """Each deviation's tolerance from a machine file's ``[tolerances]``: its own entry,
    else the default (None when neither is given)."""
    per = dict(per_deviation or {})
    return {name: per.get(name, default_mm) for name in names}


def acceptance_json(as_found: Acceptance, as_left: Acceptance) -> dict:
    """The record's ``acceptance``: the rule, then each stage."""
    return {"rule": as_found.rule, "as_found": as_found.to_json(),
            "as_left": as_left.to_json()}


def json_mm(value: float | None) -> float | None:
    """A number for JSON, to 1e-9 (mm); None where there is none (JSON has no infinity)."""
    return None if value is None or not math.isfinite(value) else round(float(value), 9)
