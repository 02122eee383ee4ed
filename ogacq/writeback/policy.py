"""Deciding what to write: the plan of old -> new per axis and the reasons to refuse it.

A plan is pure data built from the evidence (the campaign's identified
offsets), what the controller holds now and what the profile allows. Every
reason not to write is collected, not just the first, so the operator sees
the whole case; ``--force`` writes past them and the audit record keeps them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Literal, TypeVar

from ogacq_drivers.axes.profile import Profile
from ogacq.model.parameters import AXES
from ogacq.model.units import signed_per_axis as _fmt
from ogacq.writeback.audit import Operation
from ogacq.writeback.outcome import Stage

if TYPE_CHECKING:  # the evidence module pulls in the fit and scipy; the CLI imports this one
    from ogacq.writeback.evidence import Evidence

DEFAULT_MAX_CHANGE_MM = 2.0
SOFTWARE_RESOLUTION_MM = 1e-6  # the software table keeps what it is given; below any physics

Action = Literal["write", "restore"]
_T = TypeVar("_T")


@dataclass(frozen=True)
class WritePolicy:
    max_change_mm: float = DEFAULT_MAX_CHANGE_MM  # larger changes are implausible for a zero error


@dataclass(frozen=True)
class ControllerFacts:
    """What the profile says about offsets: where they live and when they act."""

    profile: str
    kind: Literal["software", "home_offset"]
    resolution_mm: float  # smallest step the offset is stored with
    margin_mm: float  # the controller's limits leave this much room beyond the soft limits
    takes_effect: Literal["now", "at_next_homing"]
    write_when_disabled: bool
    has_nvm: bool

    @classmethod
    def of(cls, profile: Profile) -> ControllerFacts:
        software = profile.offset.kind == "software"
        return cls(
            profile=profile.name, kind=profile.offset.kind,
            resolution_mm=SOFTWARE_RESOLUTION_MM if software
            else 1.0 / profile.codec.counts_per_mm,
            margin_mm=profile.limits.margin_mm,
            takes_effect="now" if software else "at_next_homing",
            write_when_disabled=profile.offset.write_when_disabled,
            has_nvm=profile.nvm.kind != "none")

    def quantize(self, value_mm: float) -> float:
        """The value as the controller (or table) will store it."""
        steps = round(value_mm / self.resolution_mm)
        return round(steps * self.resolution_mm, 9)

    def same(self, a_mm: float, b_mm: float) -> bool:
        return abs(a_mm - b_mm) <= self.resolution_mm / 2 + 1e-9


@dataclass(frozen=True)
class Refusal:
    """One reason not to write, with a stable code for scripts and tests."""

    code: str  # inconsistent, unjudged, unidentifiable, not_converged, too_large, beyond_margin,
    #            incomplete, unknown_baseline, mixed_baseline, stale, other_profile
    message: str


@dataclass(frozen=True)
class AxisChange:
    axis: str
    current_mm: float  # held by the controller (or the table) now
    new_mm: float  # as it will be stored

    @property
    def change_mm(self) -> float:
        return self.new_mm - self.current_mm


@dataclass(frozen=True)
class OffsetPlan:
    action: Action
    facts: ControllerFacts
    changes: tuple[AxisChange, ...]
    refusals: tuple[Refusal, ...] = ()
    notes: tuple[str, ...] = ()  # worth saying, not a reason to refuse
    # write: the offsets in force during the campaign the new ones are computed from
    baseline_mm: dict[str, float] = field(default_factory=dict)
    restores_operation: str | None = None  # restore: the write it undoes
    restores_unfinished: bool = False  # restore: that write failed or was cut short

    @property
    def current_mm(self) -> dict[str, float]:
        return {c.axis: c.current_mm for c in self.changes}

    @property
    def new_mm(self) -> dict[str, float]:
        return {c.axis: c.new_mm for c in self.changes}

    @property
    def refused(self) -> bool:
        return bool(self.refusals)

    @property
    def nothing_to_do(self) -> bool:
        """The controller already holds the new values."""
        return _nothing_to_do(self.changes, self.facts)

    def to_json(self) -> dict:
        return {"action": self.action, "profile": self.facts.profile,
                "offset_kind": self.facts.kind, "takes_effect": self.facts.takes_effect,
                "resolution_mm": self.facts.resolution_mm,
                "current_mm": self.current_mm, "new_mm": self.new_mm,
                "change_mm": {c.axis: round(c.change_mm, 9) for c in self.changes},
                "baseline_mm": self.baseline_mm or None,
                "refusals": [{"code": r.code, "message": r.message} for r in self.refusals],
                "notes": list(self.notes), "nothing_to_do": self.nothing_to_do}


def _margin_refusals(new_mm: Mapping[str, float], facts: ControllerFacts) -> list[Refusal]:
    beyond = {a: v for a, v in new_mm.items() if abs(v) > facts.margin_mm}
    if not beyond:
        return []
    return [Refusal("beyond_margin",
                    f"new offsets {_fmt(beyond)} mm exceed the {facts.margin_mm:g} mm margin of "
                    f"profile {facts.profile!r}: the controller's limits leave only that much "
                    "room beyond the soft limits")]


def _refuse_incomplete(evidence: Evidence, facts: ControllerFacts) -> Refusal | None:
    if evidence.finished:
        return None
    return Refusal("incomplete", "the campaign did not run to its end "
                   f"({evidence.readings} readings): resume it first")


def _refuse_not_converged(evidence: Evidence, facts: ControllerFacts) -> Refusal | None:
    if evidence.converged:
        return None
    return Refusal("not_converged", f"the offsets fit did not converge: "
                   f"{evidence.fit_stop.describe()}")


def _refuse_unidentifiable(evidence: Evidence, facts: ControllerFacts) -> Refusal | None:
    if evidence.identifiable:
        return None
    why = "; ".join(evidence.identifiability_reasons) or "the design is rank deficient"
    return Refusal("unidentifiable",
                   f"the joint offsets are not identifiable from this campaign: {why}")


def _refuse_inconsistent(evidence: Evidence, facts: ControllerFacts) -> Refusal | None:
    if evidence.verdict.consistent:
        return None
    hint = ("the model leaves something out" if evidence.uncompensated else
            "the joint-offset model leaves something out (run `ogacq diagnose "
            f"{evidence.session_path}`; when it explains the readings, `--from-diagnosis` "
            "writes the offsets of its model)")
    return Refusal("inconsistent" if evidence.verdict.judged else "unjudged",
                   f"{evidence.model} fit: {evidence.verdict.describe()}; {hint}")


def _refuse_outliers(evidence: Evidence, facts: ControllerFacts) -> Refusal | None:
    if not evidence.outliers:
        return None
    one = len(evidence.outliers) == 1
    return Refusal("outlier", f"{'a reading lies' if one else 'readings lie'} far from "
                   f"{'its' if one else 'their'} repeats, which agree among themselves "
                   f"(a misread, or the gauge knocked between cycles): "
                   f"{'; '.join(evidence.outliers)}; check the setup and run the campaign "
                   f"again (`ogacq diagnose {evidence.session_path}` says more)")


def _refuse_other_profile(evidence: Evidence, facts: ControllerFacts) -> Refusal | None:
    if evidence.profile is None or evidence.profile == facts.profile:
        return None
    return Refusal("other_profile",
                   f"the campaign ran with controller profile {evidence.profile!r}, "
                   f"this controller has {facts.profile!r}")


# The checks of the evidence alone, in the order the operator reads their refusals.
_EVIDENCE_CHECKS = (_refuse_incomplete, _refuse_not_converged, _refuse_unidentifiable,
                    _refuse_inconsistent, _refuse_outliers, _refuse_other_profile)


@dataclass(frozen=True)
class _Baseline:
    """The offsets the identified ones are relative to, and why they may not be."""

    offsets_mm: dict[str, float]
    refusal: Refusal | None


def _baseline(evidence: Evidence, current: dict[str, float]) -> _Baseline:
    if evidence.in_force_mm is None:
        return _Baseline(current, Refusal(
            "unknown_baseline",
            "the session does not record the controller offsets in force during the "
            "campaign, and the identified offsets are relative to them (with --force the "
            "current ones are assumed)"))
    mixed = None if evidence.in_force_consistent else Refusal(
        "mixed_baseline", "the controller offsets changed between the starts of this "
        "campaign (it was resumed after a change): its readings mix two baselines")
    return _Baseline(dict(evidence.in_force_mm), mixed)


def _refuse_stale(changes: tuple[AxisChange, ...], baseline: dict[str, float],
                  facts: ControllerFacts) -> Refusal | None:
    current = {c.axis: c.current_mm for c in changes}
    if _nothing_to_do(changes, facts) or all(facts.same(current[a], baseline[a]) for a in AXES):
        return None
    return Refusal(
        "stale",
        f"the controller's offsets changed since this campaign (then {_fmt(baseline)}, "
        f"now {_fmt(current)} mm): a later write-back or a manual change; writing would "
        "replace them with this campaign's result")


def _refuse_too_large(changes: tuple[AxisChange, ...], policy: WritePolicy) -> Refusal | None:
    too_large = {c.axis: c.change_mm for c in changes if abs(c.change_mm) > policy.max_change_mm}
    if not too_large:
        return None
    return Refusal(
        "too_large",
        f"changes {_fmt(too_large)} mm exceed the {policy.max_change_mm:g} mm limit "
        "(--max-change-mm): implausible for an encoder zero error; check the set-up")


def _nothing_to_do(changes: tuple[AxisChange, ...], facts: ControllerFacts) -> bool:
    return all(facts.same(c.current_mm, c.new_mm) for c in changes)


def _uncompensated_note(evidence: Evidence) -> str | None:
    if not evidence.uncompensated:
        return None
    return (f"these are the joint offsets of the model with "
            f"{', '.join(evidence.uncompensated)}; the controller cannot compensate "
            f"{'that effect' if len(evidence.uncompensated) == 1 else 'those effects'}"
            ": they remain until the machine is adjusted mechanically")


def _noise_note(evidence: Evidence, changes: tuple[AxisChange, ...],
                facts: ControllerFacts) -> str | None:
    small = [a for a in AXES if math.isfinite(evidence.std_mm[a])
             and abs(evidence.identified_mm[a]) < 2 * evidence.std_mm[a]]
    if not small or _nothing_to_do(changes, facts):
        return None
    return (f"the identified offsets of {', '.join(small)} are within two std of zero: "
            "their change is noise")


def _rounding_note(wanted_mm: dict[str, float], new_mm: dict[str, float],
                   facts: ControllerFacts) -> str | None:
    residue = [abs(new_mm[a] - wanted_mm[a]) for a in AXES]
    if facts.kind == "software" or not any(r > 1e-9 for r in residue):
        return None
    return (f"rounded to the register step {facts.resolution_mm:g} mm: up to "
            f"{max(residue):.4f} mm remains")


def _going_back_refusals(changes: tuple[AxisChange, ...], facts: ControllerFacts,
                         profile: str | None, where: str) -> list[Refusal]:
    """Going back to offsets ``where`` (written to, were on) a ``profile`` controller: on
    a controller of another profile, or beyond its margin."""
    other = [] if profile in (None, facts.profile) else [Refusal(
        "other_profile", f"{where} a {profile!r} controller, this one is {facts.profile!r}")]
    return other + _margin_refusals({c.axis: c.new_mm for c in changes}, facts)


def _present(*found: _T | None) -> tuple[_T, ...]:
    return tuple(x for x in found if x is not None)


def plan_write(evidence: Evidence, current_mm: Mapping[str, float], facts: ControllerFacts,
               policy: WritePolicy = WritePolicy()) -> OffsetPlan:
    """Old -> new per axis (``o_new = o_campaign - drho``) and every reason not to:
    the evidence's checks, then the baseline's, then the plan's."""
    current = {a: float(current_mm[a]) for a in AXES}
    baseline = _baseline(evidence, current)
    wanted = {a: baseline.offsets_mm[a] - evidence.identified_mm[a] for a in AXES}
    new = {a: facts.quantize(wanted[a]) for a in AXES}
    changes = tuple(AxisChange(a, current[a], new[a]) for a in AXES)
    refusals = _present(*(check(evidence, facts) for check in _EVIDENCE_CHECKS),
                        baseline.refusal,
                        _refuse_stale(changes, baseline.offsets_mm, facts),
                        _refuse_too_large(changes, policy)) + tuple(_margin_refusals(new, facts))
    notes = _present(_uncompensated_note(evidence), _noise_note(evidence, changes, facts),
                     _rounding_note(wanted, new, facts))
    return OffsetPlan("write", facts, changes, refusals, notes, baseline.offsets_mm)


def plan_restore(operation: Operation, current_mm: Mapping[str, float],
                 facts: ControllerFacts) -> OffsetPlan:
    """Put back the values an earlier write-back (its audit records) replaced."""
    old = {a: float(operation.old_mm[a]) for a in AXES}
    written = {a: float(operation.new_mm[a]) for a in AXES}
    if not all(math.isfinite(v) for v in (*old.values(), *written.values())):
        raise ValueError(f"write-back {operation.operation} recorded no usable values")
    current = {a: float(current_mm[a]) for a in AXES}
    changes = tuple(AxisChange(a, current[a], facts.quantize(old[a])) for a in AXES)
    refusals: list[Refusal] = []

    def expected(axis: str) -> bool:
        # a write (or a restore of it) cut short may have changed some axes only; an
        # axis back at its old value is restored already, whoever put it there
        return facts.same(current[axis], written[axis]) or facts.same(current[axis], old[axis])

    if not _nothing_to_do(changes, facts) and not all(expected(a) for a in AXES):
        refusals.append(Refusal(
            "stale",
            f"the controller no longer holds what write-back {operation.operation} wrote "
            f"({_fmt(written)}; now {_fmt(current)} mm): restoring would undo a later change"))
    refusals += _going_back_refusals(changes, facts, operation.profile,
                                     f"write-back {operation.operation} went to")
    notes = []
    if operation.status != Stage.DONE:
        notes.append(f"write-back {operation.operation} did not finish ({operation.status})")
    if operation.nvm_saved and facts.has_nvm:
        notes.append("the write-back saved its values to non-volatile memory: save the "
                     "restored ones too (--save-nvm), or a power cycle brings them back")
    return OffsetPlan("restore", facts, changes, tuple(refusals), tuple(notes),
                      restores_operation=operation.operation,
                      restores_unfinished=operation.status != Stage.DONE)


def plan_return(target_mm: Mapping[str, float | None], state: str, current_mm: Mapping[str, float],
                facts: ControllerFacts, *, profile: str | None,
                expected_mm: Mapping[str, float | None] | None) -> OffsetPlan:
    """Go back to an offsets state the history recorded (``state``: its id).

    ``expected_mm``: what the history says the controller holds now (its last finished
    write-back or restore); a controller holding something else was changed outside
    the history, and going back would undo that change unseen: refused as stale.
    """
    target = {a: v for a in AXES if (v := target_mm.get(a)) is not None and math.isfinite(v)}
    if len(target) < len(AXES):
        raise ValueError(f"offsets state {state} recorded no usable values")
    current = {a: float(current_mm[a]) for a in AXES}
    changes = tuple(AxisChange(a, current[a], facts.quantize(float(target[a]))) for a in AXES)
    refusals: list[Refusal] = []
    if expected_mm is not None and not _nothing_to_do(changes, facts) and not all(
            (e := expected_mm.get(a)) is not None and facts.same(current[a], float(e))
            for a in AXES):
        recorded = ", ".join(f"{a} {expected_mm[a]:+.4f}" if expected_mm.get(a) is not None
                             else f"{a} unknown" for a in AXES)
        refusals.append(Refusal(
            "stale",
            f"the controller holds {_fmt(current)} mm, but the history's last write-back "
            f"left {recorded}: a change the history does not know, which going back would "
            "undo"))
    refusals += _going_back_refusals(changes, facts, profile, f"offsets state {state} was on")
    return OffsetPlan("restore", facts, changes, tuple(refusals), restores_operation=state)
