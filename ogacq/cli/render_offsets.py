"""Rendering for ``ogacq offsets``: the evidence, the plan, the outcome, the history."""

from __future__ import annotations

import time
from pathlib import Path

from ogacq.cli.plain import console as new_console
from ogacq.cli.plain import shown, table_of
from ogacq.cli.render_fit import format_number as _mm  # a value in mm, '-' if none
from ogacq.cli.verdict_text import paragraph
from ogacq.writeback.audit import Operation
from ogacq.writeback.evidence import Evidence
from ogacq.writeback.execute import WriteOutcome
from ogacq.writeback.policy import OffsetPlan

console = new_console()
err_console = new_console(stderr=True)


def _where(plan: OffsetPlan, port: str, offsets_file: str | None) -> str:
    if plan.facts.kind == "software":
        return f"software offset table {offsets_file or '(none configured)'}"
    return f"{plan.facts.profile} controller at {port}"


def print_evidence(evidence: Evidence) -> None:
    console.print(f"[bold]{shown(evidence.session_path)}[/]: {evidence.readings} readings"
                  + ("" if evidence.finished else " [yellow](campaign not finished)[/]"))
    verdict = evidence.verdict
    colour = "green" if verdict.consistent else "red"
    console.print(f"{shown(evidence.model)} fit: [{colour}]{shown(paragraph(verdict))}[/]")
    if evidence.identifiable:
        console.print("identifiable: every joint offset is determined by this campaign")
    else:
        console.print("[red]not identifiable[/]: "
                      + shown("; ".join(evidence.identifiability_reasons) or "rank deficient"))


def print_plan(plan: OffsetPlan, *, port: str, offsets_file: str | None,
               evidence: Evidence | None = None) -> None:
    title = (f"joint offsets o (mm, q = raw - o): {plan.action} to "
             f"{_where(plan, port, offsets_file)}")
    # the fit std: the noise alone (U is the record's)
    campaign = [">in force during campaign", ">identified drho", ">fit std"]
    table = table_of("axis", *(campaign if evidence is not None else []),
                     ">table now" if plan.facts.kind == "software" else ">controller now",
                     ">new", ">change", title=shown(title), title_justify="left")
    for change in plan.changes:
        row = [shown(change.axis)]
        if evidence is not None:
            a = change.axis
            row += [_mm(plan.baseline_mm.get(a)), _mm(evidence.identified_mm[a]),
                    _mm(evidence.std_mm[a]).lstrip("+")]
        row += [_mm(change.current_mm), _mm(change.new_mm), _mm(change.change_mm)]
        table.add_row(*row)
    console.print(table)
    when = ("takes effect at the next homing (the axes are re-homed after writing)"
            if plan.facts.takes_effect == "at_next_homing"
            else "applied by ogacq to every commanded position from the next command on")
    prefix = ("new offsets = in force during the campaign - identified; "
              if plan.action == "write" else "restored offsets: ")
    console.print(prefix + when)
    for note in plan.notes:
        console.print(f"note: {shown(note)}")
    if plan.restores_operation:
        console.print(f"restores the values write-back {shown(plan.restores_operation)} "
                      "replaced")


def print_refusals(plan: OffsetPlan, forced: bool) -> None:
    # one line each to a log or a pipe; on a terminal wrapped between words (the
    # terminal would cut a word where its width falls)
    whole = not err_console.is_terminal
    for refusal in plan.refusals:  # unforced, the command's one-line refusal follows
        said = ("warning: --force writes past" if forced
                else f"refused ({shown(refusal.code)})")
        err_console.print(f"ogacq: {said}: {shown(refusal.message)}", soft_wrap=whole)


def print_outcome(outcome: WriteOutcome) -> None:
    done = "restored" if outcome.action == "restore" else "written"
    console.print(f"[green]{done}[/] and read back ({shown(outcome.operation)}): "
                  + shown(", ".join(f"{a} {_mm(v)}" for a, v in outcome.new_mm.items())) + " mm")
    if outcome.offsets_file is not None:
        console.print(f"software offset table {shown(outcome.offsets_file)}: every campaign "
                      "with this campaign file now applies it")
    if outcome.rehomed and outcome.home_positions_mm is not None:
        console.print("re-homed: at the home point the axes read "
                      + shown(", ".join(f"{a} {_mm(q, 3)}" for a, q in
                                        outcome.home_positions_mm.items())) + " mm (= -o)")
    elif outcome.pending_homing:
        console.print("[yellow]not re-homed: the new offsets take effect at the next homing "
                      "(every campaign homes first)[/]")
    if outcome.nvm_saved:
        console.print("saved to non-volatile memory: they survive a power cycle of the drive")
    elif outcome.offsets_file is None:
        console.print("[yellow]NOT saved to non-volatile memory: switching the drive off and on "
                      "brings back the offsets it saved before[/] (`ogacq offsets write "
                      "--save-nvm` saves them; a campaign after a power cycle then homes with "
                      "the old ones)")
    if outcome.action == "write":
        console.print("old and new values are recorded in the session (`ogacq offsets "
                      "restore` puts the old ones back)")
    else:
        console.print("recorded in the session")


def print_history(operations: list[Operation]) -> None:
    if not operations:
        return
    console.print("[bold]write-backs recorded in this session[/]")
    for op in operations:
        when = time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(op.wall)) if op.wall else "?"
        console.print(shown(f"  {when} {op.operation} {op.action} [{op.status}]: "
                            + ", ".join(f"{a} {_mm(op.old_mm.get(a))} -> {_mm(op.new_mm.get(a))}"
                                        for a in op.old_mm)))


def print_validation_next(campaign: str | None, session: Path, from_diagnosis: bool) -> None:
    """After a write: the validation run that says whether the offsets took, naming the
    campaign file and the session it records into."""
    from ogacq.cli.campaign_end import next_session_name

    if not campaign:
        console.print(f"next: a validation campaign, then `ogacq report {shown(session)} "
                      "--after VALIDATION_SESSION`")
        return
    model = ("; its end judges it with the effects named above carried over: they stay "
             "on the machine" if from_diagnosis else "")
    console.print(f"next: ogacq run {shown(campaign)}   (the validation, recorded as "
                  f"{shown(next_session_name(Path(campaign), session))}{model}; then "
                  f"`ogacq report {shown(session)} --after` it)")
