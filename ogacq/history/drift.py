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

Where both records say which offsets the controller held during their campaigns
(``controller.offsets_mm``, read at every start), the change is judged by those
instead: the offset the machine needs is the one in force minus the one identified,
and a change of it is the machine's, whoever changed the controller in between. A
controller whose offsets moved other than by the recorded write-backs (reset by a
drive's replacement or a parameter reload, edited by hand, another tool's write)
is then no drift of the machine, and :func:`controller_changes` names it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

from ogacq.history.entries import Calibration, OffsetState, Parameter

COVERAGE_K = 2.0  # for a std standing in for u_c (JCGM 100:2008 6.2.1)
# Offsets read back from a controller are the same number when equal; this only keeps
# a float's last digit from being called a change (far below any register's step).
OFFSET_EQUAL_MM = 1e-6

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
    # how far the controller's offset moved between the two campaigns, by the offsets
    # both recorded in force (None: not both known; the written ones then stand in)
    controller_moved_mm: float | None = None

    @property
    def shift_mm(self) -> float:
        """What the later value is compared with is the earlier plus this."""
        return self.written_mm if self.controller_moved_mm is None else self.controller_moved_mm

    def describe(self) -> str:
        word = "drift" if self.flagged else "change"
        note = "" if self.basis == "U" else " (U unknown: 2 x the fit's std used)"
        if self.controller_moved_mm is not None:
            left = (f" (from the offsets in force: the controller's moved "
                    f"{self.controller_moved_mm:+.4f} mm between the campaigns)"
                    if abs(self.controller_moved_mm) > OFFSET_EQUAL_MM else "")
        else:
            left = (f" (from the state as left: its value {self.written_mm:+.4f} mm written "
                    "back)" if self.written_mm else "")
        return (f"{word}: {self.parameter} {self.change_mm:+.4f} mm from {self.from_record} to "
                f"{self.to_record}{left}, U of the change {self.limit_mm:.4f} mm{note}")

    def to_json(self) -> dict[str, Any]:
        return {"parameter": self.parameter, "from": self.from_record, "to": self.to_record,
                "from_date": self.from_date, "to_date": self.to_date,
                "change_mm": round(self.change_mm, 9), "U_change_mm": round(self.limit_mm, 9),
                "basis": self.basis, "flagged": self.flagged,
                "written_mm": round(self.written_mm, 9),
                "controller_moved_mm": None if self.controller_moved_mm is None
                else round(self.controller_moved_mm, 9)}


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
    both have, from the offsets in force where both recorded them, else from the state
    as left (``written``: :func:`written_by_record`), with its U; those larger than it
    flagged."""
    out: list[Drift] = []
    for before, after in _judged_pairs(calibrations):
        wrote = (written or {}).get(before.record_id, {})
        moved_by = _moved(before, after)
        for name, now in after.parameters.items():
            then = before.parameters.get(name)
            if then is None:
                continue
            u_then, basis_then = expanded(then)
            u_now, basis_now = expanded(now)
            if u_then is None or u_now is None:
                continue  # nothing to judge the change against
            limit = math.hypot(u_then, u_now)
            moved = moved_by.get(name)
            shift = wrote.get(name, 0.0) if moved is None else moved
            change = now.value_mm - (then.value_mm + shift)
            basis: Basis = "U" if basis_then == basis_now == "U" else "std"
            out.append(Drift(name, before.record_id, after.record_id, before.date, after.date,
                             change, limit, basis, abs(change) > limit, wrote.get(name, 0.0),
                             moved))
    return out


@dataclass(frozen=True)
class ControllerChange:
    """The controller's offsets moved between two campaigns other than by the
    write-backs recorded from the earlier one."""

    from_record: str
    to_record: str
    then_mm: dict[str, float]  # in force during the earlier campaign
    now_mm: dict[str, float]  # in force during the later one
    written_mm: dict[str, float]  # the net change the recorded write-backs made
    unexplained_mm: dict[str, float]  # per axis, moved minus written (only those moved)

    def describe(self) -> str:
        moves = ", ".join(f"{p.removeprefix('joint_offset.')} {v:+.4f}"
                          for p, v in self.unexplained_mm.items())
        return (f"controller: its joint offsets changed outside ogacq between "
                f"{self.from_record} and {self.to_record} ({moves} mm beyond the recorded "
                "write-backs): a reset, a replaced drive or a hand edit; judged from the "
                "offsets in force, so not a drift of the machine")

    def to_json(self) -> dict[str, Any]:
        return {"from": self.from_record, "to": self.to_record, "then_mm": self.then_mm,
                "now_mm": self.now_mm, "written_mm": self.written_mm,
                "unexplained_mm": self.unexplained_mm}


def controller_changes(calibrations: Sequence[Calibration],
                       written: dict[str, dict[str, float]] | None = None,
                       ) -> list[ControllerChange]:
    """Each pair of successive calibrations (oldest first) between which the controller's
    offsets in force moved by more than the write-backs recorded from the earlier."""
    out = []
    for before, after in _judged_pairs(calibrations):
        if before.simulated or after.simulated:
            continue  # each rehearsal may start a new simulator: a new controller
        moved = _moved(before, after)
        wrote = (written or {}).get(before.record_id, {})
        beyond = {name: m - wrote.get(name, 0.0) for name, m in moved.items()
                  if abs(m - wrote.get(name, 0.0)) > OFFSET_EQUAL_MM}
        if beyond:  # moved is empty unless both recorded their offsets in force
            assert before.offsets_in_force_mm and after.offsets_in_force_mm
            out.append(ControllerChange(
                before.record_id, after.record_id, dict(before.offsets_in_force_mm),
                dict(after.offsets_in_force_mm),
                {name: wrote.get(name, 0.0) for name in moved}, beyond))
    return out


def _judged_pairs(calibrations: Sequence[Calibration],
                  ) -> list[tuple[Calibration, Calibration]]:
    """Successive calibrations, rehearsals kept apart from the machine's: each list
    (real, simulated) compared within itself (a rehearsal between two calibrations of
    the machine does not hide the change between them)."""
    pairs = []
    for simulated in (False, True):
        kind = [c for c in calibrations if bool(c.simulated) == simulated]
        pairs += list(zip(kind, kind[1:], strict=False))
    return pairs


def _moved(before: Calibration, after: Calibration) -> dict[str, float]:
    """joint_offset.<axis> -> how far the controller's offset moved between the two
    campaigns ({} unless both recorded their offsets in force)."""
    then, now = before.offsets_in_force_mm, after.offsets_in_force_mm
    if not then or not now:
        return {}
    return {f"joint_offset.{a}": now[a] - then[a] for a in then if a in now}
