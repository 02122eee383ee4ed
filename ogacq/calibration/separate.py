"""When the diagnosis is ambiguous, the measurement that would separate it.

Ambiguous here means one of:

* an effect of the final model has alternatives that explain the readings as well
  (the diagnosis's swap test), or rests on one reading cell;
* the misfit is not explained, or only partly: something outside the library, a
  lead screw's error or a bow, which a map describes;
* an effect a table would correct (an encoder scale, a lost motion) was found from a
  few positions per leg, where an error depending on the position in another way (a
  lead-screw pitch error) passes for it: the diagnosis's own caveat;
* an error map is among an effect's alternatives;
* the joint offsets rest on a few positions per leg (the papers' three): between
  them no axis was measured, and an error whose period divides their spacing (a 4 mm
  lead on the postures 0, +60 and -100 mm) reads the same at each and passes for an
  offset, which a validation at the same postures confirms.

Where a map is suspected (the last four) the measurement is a scan of every leg's
travel, both directions, its targets designed for the machine's drives within the
time budget (``ogacq.protocol.scan_design``), or every ``--scan-step-mm`` when one is
given; where only alternatives stand, the plan the diagnosis found that separates
them (``ogacq.diagnose.separation``). Its duration is estimated from the campaign
already run on this machine: its machine time per reading step, times the plan's
reading steps.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

from ogacq.calibration.maps import compensable_effects
from ogacq.diagnose.diagnosis import FEW_POSTURES, Diagnosis
from ogacq.model.error_maps import FAMILIES as MAP_FAMILIES
from ogacq.model.machine import MachineSpec
from ogacq.model.parameters import AXES
from ogacq.protocol.plan import ProtocolConfig, reading_steps
from ogacq.protocol.scan_design import ScanDesign, design_scan
from ogacq.session.store import LoadedSession


@dataclass(frozen=True)
class SeparatingPlan:
    reasons: tuple[str, ...]  # why the diagnosis is ambiguous; empty: it is not
    protocol: ProtocolConfig | None  # None: nothing to run (not ambiguous, or no plan)
    kind: str  # "scan", "postures" or "none"
    steps: int  # reading steps of the plan
    duration_s: float  # estimated machine time
    seconds_per_step: float
    why_none: str = ""
    design: ScanDesign | None = None  # the designed scan's (None: postures, a fixed step)

    def to_json(self) -> dict[str, Any]:
        return {"reasons": list(self.reasons), "kind": self.kind,
                "protocol": self.protocol.to_dict() if self.protocol else None,
                "reading_steps": self.steps, "duration_s": round(self.duration_s, 1),
                "seconds_per_step": round(self.seconds_per_step, 3),
                "why_none": self.why_none or None,
                "design": self.design.to_json() if self.design else None}


def ambiguity(diagnosis: Diagnosis) -> tuple[list[str], bool]:
    """Why the diagnosis is ambiguous (empty: it is not), and whether a map is suspected."""
    reasons = []
    suspected = False
    if diagnosis.outcome in ("unexplained", "partly explained"):
        suspected = True
        reasons.append(f"the diagnosis is {diagnosis.outcome}"
                       + (f" (the rest at {diagnosis.unexplained})"
                          if diagnosis.unexplained else "")
                       + ": an error outside the library, which a map describes")
    for effect in diagnosis.effects:
        if effect.alternatives:
            reasons.append(f"{effect.name} has alternatives: "
                           + ", ".join(a.name for a in effect.alternatives))
        maps = [a.name for a in effect.alternatives if a.name.split(".")[0] in MAP_FAMILIES]
        if maps:
            # A plan of a few more postures could only say "a map": the table a
            # controller needs is the scan's, so the scan is the separating measurement.
            suspected = True
            reasons.append(f"an error map ({', '.join(maps)}) explains the readings as well "
                           f"as {effect.name}: only a scan tells them apart and tabulates it")
        if effect.local_disturbance:
            reasons.append(f"{effect.name} rests on one cell ({effect.local_disturbance})")
    tabled = compensable_effects(diagnosis)
    few = diagnosis.postures_per_leg <= FEW_POSTURES
    if tabled and few:
        suspected = True
        reasons.append(f"{', '.join(tabled)} found from {diagnosis.postures_per_leg} positions "
                       "per leg: a lead-screw error would pass for it there")
    elif few:
        suspected = True
        reasons.append(f"the joint offsets rest on {diagnosis.postures_per_leg} positions per "
                       "leg: between them no axis was measured, and a lead that divides their "
                       "spacing reads alike at each and passes for an offset")
    return reasons, suspected


def steps_of(protocol: ProtocolConfig, machine: MachineSpec) -> int:
    return len(reading_steps(protocol, machine))


def seconds_per_step(session: LoadedSession) -> float:
    """Machine time per reading step of a finished campaign (its last reading's time
    over its reading steps)."""
    readings = session.readings
    steps = {r.step for r in readings}
    if not readings or not steps:
        return 0.0
    return max(r.t_s for r in readings) / len(steps)


def separating_plan(diagnosis: Diagnosis, session: LoadedSession, machine: MachineSpec,
                    scan: ProtocolConfig, *, designed: bool = True,
                    budget_s: float | None = None, grow: bool = True) -> SeparatingPlan:
    """The measurement that would separate what the diagnosis of ``session`` leaves
    open: where a map is suspected the scan designed for ``machine`` within
    ``budget_s`` of machine time (``designed``; ``grow``: grown within it toward the
    detection target), else ``scan``, a scan every step."""
    reasons, suspected = ambiguity(diagnosis)
    rate = seconds_per_step(session)
    if not reasons:
        return SeparatingPlan((), None, "none", 0, 0.0, rate, "the diagnosis is not ambiguous")
    if suspected and designed:
        design = design_scan(machine, scan, noise_mm=diagnosis.noise.sigma_mm,
                             seconds_per_step=rate, budget_s=budget_s, grow=grow)
        return SeparatingPlan(tuple(reasons), design.protocol, "scan", design.steps,
                              design.duration_s, rate, design=design)
    if suspected:
        steps = steps_of(scan, machine)
        return SeparatingPlan(tuple(reasons), scan, "scan", steps, steps * rate, rate)
    for effect in diagnosis.effects:
        for sep in effect.separations:
            option = sep.separating
            if option is not None:
                protocol = ProtocolConfig(postures=tuple(option.postures), cycles=option.cycles,
                                          settle_s=scan.settle_s)
                steps = steps_of(protocol, machine)
                return SeparatingPlan(tuple(reasons), protocol, "postures", steps,
                                      steps * rate, rate)
    return SeparatingPlan(tuple(reasons), None, "none", 0, 0.0, rate,
                          "none of the plans tried separates them (a measurement of another "
                          "kind is needed)")


def offsets_carried(diagnosis: Diagnosis) -> Diagnosis:
    """What the calibration campaign carries when the separating scan contradicts its
    effects: its joint offsets alone where they are within the gauge noise (an effect
    found at three postures per leg, which a scan could not confirm, is no ground for
    offsets: a leg length standing in for a lead's error left them unidentifiable), its
    whole diagnosis otherwise."""
    if not diagnosis.base.consistent:
        return diagnosis
    return replace(diagnosis, claimed=diagnosis.selection.base, final_fit=diagnosis.base_fit,
                   effects=[], mapped=None)


def not_established(scanned: Diagnosis, before: Diagnosis) -> str:
    """Why the separating scan's diagnosis cannot be written (empty: it can), where the
    calibration campaign's is within the gauge noise (the offsets then go as far as
    their own campaign carries them, the maps said to be not established):

    * its final model is not within the gauge noise: an error of another kind, or one
      its targets cannot resolve;
    * it sees a cyclic error beyond the noise whose pitch it does not resolve (another
      pitch fits alike: ``mapsearch._rival_pitch``): a map of either pitch, or a smooth
      map standing in for it, is a guess where the readings do not see the joint (a
      15 mm pitch written for a 20 mm lead left 3.5 µm rms of 2.8; a smooth map in its
      place, 16 µm)."""
    if not before.final.consistent:
        return ""
    unresolved = [] if scanned.mapped is None else scanned.mapped.search.unresolved
    if scanned.final.consistent and not unresolved:
        return ""
    if not scanned.final.consistent:
        # the maps it found, tabulated or not (they are not while its fit is not within
        # the noise: "no map" was said of a 4 µm lead found to 1 %)
        found = [e.name for e in scanned.mapped.effects] if scanned.mapped else []
        maps = ", ".join(found) or "no map"
        why = f"the separating scan's diagnosis ({maps}) fits {scanned.final.describe()}"
        would = ("a scan that resolves the rest (a longer --scan-minutes, the leads stated "
                 "in the machine file's screws table), or the same scan read again should "
                 f"this be the one time in {1 / scanned.final.level:.0f} that a right model "
                 "fails the test,")
    else:
        why = ("the separating scan sees a cyclic error whose pitch it does not resolve ("
               + "; ".join(f"{AXES[c.term.axis]} axis: {c.unresolved}" for c in unresolved)
               + "): a map of either pitch, or one in its place, would be a guess beyond "
               "where its readings see the joint")
        would = ("a measurement that sees the joint over its whole travel (a positioning "
                 "test along the axis, ISO 230-2, by a scale along its actuator: "
                 "[axis_scale.AXIS] in the campaign file, `ogacq positioning`)")
    return (f"error maps not established: {why}; the offsets are those of the calibration "
            f"campaign, within the noise; {would} would establish the maps")
