"""What ``ogacq calibrate`` shows: each campaign's progress, the diagnoses, the
separating measurement with its duration, the compensation with its tables and the
ISO 230-2 figures, the question, the validation and the outcome."""

from __future__ import annotations

import contextlib
from pathlib import Path
from typing import Any

from ogacq.calibration.compensate import TABLES_FOLDER, Compensation
from ogacq.calibration.procedure import NOT_APPLIED_FILE, Outcome
from ogacq.calibration.separate import SeparatingPlan
from ogacq.calibration.validate import Judgement
from ogacq.cli import render_offsets
from ogacq.cli.campaign_end import NextStep, step_lines
from ogacq.cli.options import confirmed
from ogacq.cli.plain import Printer, shown, table_of
from ogacq.cli.plain import console as new_console
from ogacq.cli.render import CampaignProgress, campaign_progress
from ogacq.cli.verdict_text import paragraph, recorded_paragraph
from ogacq.compensation.iso230 import Iso230Figures, map_figures
from ogacq.diagnose.diagnosis import Diagnosis
from ogacq.diagnose.maps import MapEffect
from ogacq.model.units import UM_PER_MM
from ogacq.record.calibration_record import CalibrationRecord
from ogacq.uncertainty.reporting import measure
from ogacq.writeback.maps import MapsPlan
from ogacq.writeback.outcome import WriteOutcome
from ogacq.writeback.policy import OffsetPlan

console = new_console()


def _duration(seconds: float) -> str:
    return f"{seconds / 60:.1f} min" if seconds >= 120 else f"{seconds:.0f} s"


class TerminalUI:
    """The procedure's UI on the command line (``ogacq.calibration.procedure``)."""

    def __init__(self, *, yes: bool, on_recorded: Any, where: str = "the controller",
                 offsets_file: str | None = None) -> None:
        self.yes = yes
        self.where = where
        self.offsets_file = offsets_file
        self._on_recorded = on_recorded
        self._stack = contextlib.ExitStack()
        # each map's figures after as predicted (the write's map, its error taken away):
        # what the validation's figures are said beside
        self._predicted: dict[str, Iso230Figures] = {}
        # what "no error map" leaves possible: the cyclic error below the size the
        # separating scan finds reliably (its design's)
        self._may_remain = ""

    def close(self) -> None:
        self._stack.close()

    def say(self, text: str) -> None:
        console.print(text)

    def observer(self, role: str) -> CampaignProgress:
        self._stack.close()
        self._stack = contextlib.ExitStack()
        return self._stack.enter_context(campaign_progress())

    def diagnosis(self, role: str, diagnosis: Diagnosis) -> None:
        self._stack.close()
        # as the record's Diagnosis table: value ± std (k = 1), the value to the std's
        # decimal place (JCGM 100:2008 7.2.6; it was "+408.3 ± 18 ppm")
        effects = "; ".join(e.sentence() if isinstance(e, MapEffect)
                            else f"{e.name} {measure(e.value, e.std, e.unit)}"
                            for e in diagnosis.effects) or "none"
        console.print(f"diagnosis of the {role} campaign: {diagnosis.outcome}; effects "
                      f"(value ± std, k = 1): {effects}")
        console.print(f"  {paragraph(diagnosis.final)}")

    def separation(self, plan: SeparatingPlan, speed: float | None) -> None:
        if not plan.reasons:
            console.print("the diagnosis is not ambiguous: no separating measurement")
            return
        console.print("the diagnosis is ambiguous: " + "; ".join(plan.reasons))
        if plan.protocol is None:
            console.print(f"  no separating measurement: {plan.why_none}")
            return
        what = ("the designed scan of each leg" if plan.design is not None else
                f"a scan every {plan.protocol.scan_step_mm:g} mm along each leg, both "
                "directions" if plan.kind == "scan"
                else "postures " + ",".join(str(p) for p in plan.protocol.postures))
        wall = f" (about {_duration(plan.duration_s / speed)} here at {speed:g}x)" if speed \
            else ""
        console.print(f"  separating measurement: {what}, {plan.steps} reading steps, about "
                      f"{_duration(plan.duration_s)} of machine time at this machine's "
                      f"{plan.seconds_per_step:.1f} s per step{wall}")
        for line in plan.design.lines() if plan.design is not None else ():
            console.print(f"    {line}")
        if plan.design is not None:
            self._may_remain = plan.design.may_remain()

    def compensation(self, comp: Compensation, offsets: OffsetPlan,
                     maps: MapsPlan | None) -> None:
        render_offsets.print_plan(offsets, port=self.where, offsets_file=self.offsets_file)
        for r in offsets.refusals:
            console.print(f"  would refuse ({r.code}): {r.message}")
        if comp.uncompensated:
            console.print("stays uncompensated (no table corrects it): "
                          + ", ".join(comp.uncompensated))
        for why in comp.not_applied:
            console.print(f"not applied, nor tabulated: {why}")
        if not comp.maps:
            console.print("no error map to write" + (f": {self._may_remain}"
                                                     if self._may_remain else ""))
            return
        table = table_of("axis", "from", "before", "after (predicted: ogacq applies it)",
                         title="error maps (ISO 230-2:2014 figures of each axis; s = the "
                               "map's u, k = 1)", title_justify="left")
        for axis, m in comp.maps.items():
            residual = map_figures(m.__class__(
                m.axis, m.positions_mm, tuple(0.0 for _ in m.positions_mm),
                tuple(0.0 for _ in m.positions_mm), m.u_forward_mm, m.u_reverse_mm,
                m.reference_mm))
            table.add_row(axis, m.source, map_figures(m).line(), residual.line())
            self._predicted[axis] = residual
        console.print(table)
        for t in comp.tables:
            said = [", ".join(Path(f).name for f in t["files"])] if t["files"] else []
            if t["problem"]:  # the format, or some of its axes, not written: why
                said.append(f"not written: {t['problem']}")
            console.print(f"  {t['format']} table: {shown('; '.join(said))}")
        if maps is not None:
            console.print(f"maps file {shown(maps.path)}: {maps.current.checksum[:12]} -> "
                          f"{maps.new_checksum[:12]}"
                          + ("" if not maps.nothing_to_do else " (already there)"))
            for r in maps.refusals:
                console.print(f"  would refuse ({r.code}): {r.message}")

    def confirm(self, question: str) -> bool:
        return confirmed(question)

    def validation(self, judgement: Judgement) -> None:
        self._stack.close()
        console.print(f"validation: {judgement.outcome}; "
                      f"{recorded_paragraph(judgement.verdict)}")
        left = ", ".join(f"{a} {v:+.4f}" for a, v in judgement.offsets_after_mm.items())
        console.print(f"  joint offsets left: {left} mm")
        for axis, fig in judgement.figures_after.items():
            before = judgement.figures_before.get(axis, {})
            figures = ", ".join(f"{n} {before.get(f'{n}_mm', 0) * UM_PER_MM:.2f} -> "
                                f"{fig[f'{n}_mm'] * UM_PER_MM:.2f} µm" for n in "ABE")
            console.print(f"  axis {axis}: {figures} (ISO 230-2, from the maps)")
            if fig.get("drive_step_mm"):
                step = fig["drive_step_mm"] * UM_PER_MM
                console.print(f"    as left, with the drive's step ({step:g} µm a count: "
                              "each target is a whole count): A up to "
                              f"{fig['A_with_step_mm'] * UM_PER_MM:.2f} µm, E up to "
                              f"{fig['E_with_step_mm'] * UM_PER_MM:.2f} µm")
            predicted = self._predicted.get(axis)
            gap = prediction_gap(predicted, fig) if predicted is not None else None
            if gap is not None:
                console.print(f"    {gap}")
        for reason in judgement.reasons:
            console.print(f"  worse: {reason}")

    def recorded(self, session_path: Path) -> None:
        self._on_recorded(session_path)


def prediction_gap(predicted: Iso230Figures, after: dict[str, Any]) -> str | None:
    """Why the accuracy A a validation measured exceeds the one predicted, in words
    (None when it does not). Both are ISO 230-2 figures of a map with its u as the s
    (``ogacq.compensation.iso230``): A is the error left, E, widened by two u either
    side. The prediction is the written map with its error taken away, so its A is
    four u of that map (measured densely by the scan); the validation identifies
    what is left afresh, from its own readings, often fewer at fewer positions: an E
    within the predicted band and its own u, not the machine, make its A larger. An
    encoder-scale calibration predicted A 6.90 µm and its validation measured
    13.08 µm, with no comment."""
    was, now = predicted.A * UM_PER_MM, float(after["A_mm"]) * UM_PER_MM
    if now <= was:
        return None
    left = float(after["E_mm"]) * UM_PER_MM
    u_was = predicted.R / 4 * UM_PER_MM
    said = (f"A {now:.2f} µm against {was:.2f} µm predicted (no error left, two u either "
            f"side: the written map's u {u_was:.2f} µm)")
    if left > was:
        return (f"{said}: E {left:.2f} µm is left, beyond that band: the correction left "
                "part of the error")
    u_now = float(after.get("u_max_mm", after["R_mm"] / 4)) * UM_PER_MM
    return (f"{said}: this validation finds E {left:.2f} µm left, within that band, with "
            f"two u of its own measure either side (u up to {u_now:.2f} µm)"
            + (": how well it checks the axis, not an error of the machine"
               if u_now > u_was else ""))


def print_outcome(outcome: Outcome, report: Path | None) -> None:
    """The procedure's end, as every campaign's: the outcome, the record's id and page,
    and the next command."""
    words: dict[str, str] = {WriteOutcome.VALIDATED: "validated",
        WriteOutcome.IMPROVED: "kept (better, not within the noise)",
        WriteOutcome.RESTORED: "RESTORED to the previous state",
        WriteOutcome.DECLINED: "nothing written",
        WriteOutcome.REFUSED: "refused, nothing written",
        WriteOutcome.NOTHING_TO_CORRECT: "nothing to correct"}
    said = words.get(outcome.outcome, outcome.outcome)
    # wrapped between words at the terminal's width (one long line was cut mid-word)
    say = Printer(stderr=bool(outcome.exit_code)).print
    say(shown(f"calibration {outcome.procedure}: {said}: {outcome.reason}"))
    marked = outcome.folder / TABLES_FOLDER / NOT_APPLIED_FILE
    if marked.is_file():  # tables a technician must not load: said where they lie
        say(shown(f"the tables in {marked.parent} were not applied ({marked.name} says "
                  "why): do not load them into a controller"))
    record_id = CalibrationRecord.from_json(outcome.record).id if outcome.record else None
    if record_id or report is not None:
        say(shown("record: " + " ".join(str(part) for part in (
            record_id, f"({report})" if record_id and report else report) if part)))
    for line in step_lines(next_steps(outcome, report)):
        say(shown(line))


def next_steps(outcome: Outcome, report: Path | None) -> tuple[NextStep, ...]:
    """What to do after the procedure, most useful first."""
    evidence, validation = outcome.evidence, outcome.validation
    record = (NextStep(f"open {report}", "the calibration record: as found and as left")
              if report is not None else
              NextStep(f"ogacq report {evidence}", "the calibration record")
              if evidence is not None else None)
    steps: list[NextStep | None]
    if outcome.outcome == WriteOutcome.IMPROVED:
        steps = [NextStep(f"ogacq diagnose {validation}", "what the correction left, in "
                          "the validation campaign") if validation is not None else None,
                 NextStep("", "a second `ogacq calibrate` starts from the corrections now "
                              "in force and corrects what is left"),
                 record]
    elif outcome.outcome in (WriteOutcome.RESTORED, WriteOutcome.REFUSED):
        why = ("the correction made it worse and the previous state is back: what the "
               "calibration campaign shows" if outcome.outcome == WriteOutcome.RESTORED else
               "nothing was written (the reasons above): what the calibration campaign shows")
        steps = [NextStep(f"ogacq diagnose {evidence}", why) if evidence is not None else None,
                 record]
    else:  # validated, nothing to correct, declined
        steps = [record]
    return tuple(step for step in steps if step is not None)
