"""Changes between successive calibrations of a machine that their uncertainty does
not explain.

A change of a parameter from one calibration to the next is flagged when it is
larger than the expanded uncertainty of the change, the root sum of squares of
both calibrations' U: |x2 - x1| > sqrt(U1^2 + U2^2), i.e. |E_n| > 1 (ISO
13528:2015 section 9.7, the E_n number). The calibrations are taken as
independent; what they share (the same gauges' calibration) makes the true U of
the change smaller, so this errs towards flagging less.

A calibration whose U is unknown (no uncertainty budget) uses twice the fit's
standard deviation in its place (U = k u with k = 2, JCGM 100:2008 section
6.2.1, with the std standing in for u_c) and the flag says so.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

from ogacq.history.entries import Parameter
from ogacq.history.store import Calibration

COVERAGE_K = 2.0  # for a std standing in for u_c (JCGM 100:2008 6.2.1)

Basis = Literal["U", "std"]


@dataclass(frozen=True)
class Drift:
    """A parameter's change from one calibration to the next, against its U."""

    parameter: str
    from_record: str
    to_record: str
    from_date: str | None
    to_date: str | None
    change_mm: float
    limit_mm: float  # U of the change: sqrt(U1^2 + U2^2)
    basis: Basis  # "std": a U was unknown and 2 std stood in for it
    flagged: bool

    def describe(self) -> str:
        word = "drift" if self.flagged else "change"
        note = "" if self.basis == "U" else " (U unknown: 2 x the fit's std used)"
        return (f"{word}: {self.parameter} {self.change_mm:+.4f} mm from {self.from_record} to "
                f"{self.to_record}, U of the change {self.limit_mm:.4f} mm{note}")

    def to_json(self) -> dict[str, Any]:
        return {"parameter": self.parameter, "from": self.from_record, "to": self.to_record,
                "from_date": self.from_date, "to_date": self.to_date,
                "change_mm": round(self.change_mm, 9), "U_change_mm": round(self.limit_mm, 9),
                "basis": self.basis, "flagged": self.flagged}


def expanded(parameter: Parameter) -> tuple[float | None, Basis]:
    """The parameter's U; when it is unknown, 2 std of the fit (else 2 u, should a
    record hold u without U); None when nothing is known."""
    if parameter.expanded_mm is not None:
        return parameter.expanded_mm, "U"
    stand_in = parameter.std_mm if parameter.std_mm is not None else parameter.u_mm
    if stand_in is not None:
        return COVERAGE_K * stand_in, "std"
    return None, "std"


def changes(calibrations: Sequence[Calibration]) -> list[Drift]:
    """Every parameter's change between successive calibrations (oldest first) that
    both have, with its U; those larger than it flagged."""
    out: list[Drift] = []
    for before, after in zip(calibrations, calibrations[1:], strict=False):
        for name, now in after.parameters.items():
            then = before.parameters.get(name)
            if then is None:
                continue
            u_then, basis_then = expanded(then)
            u_now, basis_now = expanded(now)
            if u_then is None or u_now is None:
                continue  # nothing to judge the change against
            limit = math.hypot(u_then, u_now)
            change = now.value_mm - then.value_mm
            basis: Basis = "U" if basis_then == basis_now == "U" else "std"
            out.append(Drift(name, before.record_id, after.record_id, before.date, after.date,
                             change, limit, basis, abs(change) > limit))
    return out
