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

A joint offset is identified against the offsets the controller held during the
campaign, so a write-back between two calibrations changes what the next one finds
by what it wrote: the write sets o_new = o_old - identified, after which the same
machine identifies identified + (o_new - o_old), about zero. The change is therefore
judged against the state as left, the earlier value plus what was written from its
session (``written``: the net change of the offsets of every completed write-back
and restore the earlier calibration's record made), never against the value as
found.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

from ogacq.history.entries import Parameter

if TYPE_CHECKING:  # the types only: a report drawing a history needs no database
    from ogacq.history.store import Calibration, OffsetState

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
    # what the write-backs made from the earlier calibration changed this parameter by:
    # the change is the later value's from the state as left (earlier + written)
    written_mm: float = 0.0

    def describe(self) -> str:
        word = "drift" if self.flagged else "change"
        note = "" if self.basis == "U" else " (U unknown: 2 x the fit's std used)"
        left = (f" (from the state as left: its value {self.written_mm:+.4f} mm written "
                "back)" if self.written_mm else "")
        return (f"{word}: {self.parameter} {self.change_mm:+.4f} mm from {self.from_record} to "
                f"{self.to_record}{left}, U of the change {self.limit_mm:.4f} mm{note}")

    def to_json(self) -> dict[str, Any]:
        return {"parameter": self.parameter, "from": self.from_record, "to": self.to_record,
                "from_date": self.from_date, "to_date": self.to_date,
                "change_mm": round(self.change_mm, 9), "U_change_mm": round(self.limit_mm, 9),
                "basis": self.basis, "flagged": self.flagged,
                "written_mm": round(self.written_mm, 9)}


def expanded(parameter: Parameter) -> tuple[float | None, Basis]:
    """The parameter's U; when it is unknown, 2 std of the fit (else 2 u, should a
    record hold u without U); None when nothing is known."""
    if parameter.expanded_mm is not None:
        return parameter.expanded_mm, "U"
    stand_in = parameter.std_mm if parameter.std_mm is not None else parameter.u_mm
    if stand_in is not None:
        return COVERAGE_K * stand_in, "std"
    return None, "std"


def written_by_record(states: Sequence[OffsetState]) -> dict[str, dict[str, float]]:
    """record id -> parameter -> the net change of the offsets that record's session
    wrote (every completed write-back and restore: after minus before)."""
    before = {v.operation: v for v in states if v.stage == "before"}
    out: dict[str, dict[str, float]] = {}
    for after in states:
        found = before.get(after.operation)
        if after.stage != "after" or after.status != "done" or found is None:
            continue
        for axis, new in after.offsets_mm.items():
            old = found.offsets_mm.get(axis)
            if new is None or old is None:
                continue
            name = f"joint_offset.{axis}"
            written = out.setdefault(after.record_id, {})
            written[name] = written.get(name, 0.0) + (new - old)
    return out


def changes(calibrations: Sequence[Calibration],
            written: dict[str, dict[str, float]] | None = None) -> list[Drift]:
    """Every parameter's change between successive calibrations (oldest first) that
    both have, from the state as left (``written``: :func:`written_by_record`), with
    its U; those larger than it flagged."""
    out: list[Drift] = []
    for before, after in zip(calibrations, calibrations[1:], strict=False):
        wrote = (written or {}).get(before.record_id, {})
        for name, now in after.parameters.items():
            then = before.parameters.get(name)
            if then is None:
                continue
            u_then, basis_then = expanded(then)
            u_now, basis_now = expanded(now)
            if u_then is None or u_now is None:
                continue  # nothing to judge the change against
            limit = math.hypot(u_then, u_now)
            change = now.value_mm - (then.value_mm + wrote.get(name, 0.0))
            basis: Basis = "U" if basis_then == basis_now == "U" else "std"
            out.append(Drift(name, before.record_id, after.record_id, before.date, after.date,
                             change, limit, basis, abs(change) > limit, wrote.get(name, 0.0)))
    return out
