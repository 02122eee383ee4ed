"""``ogacq offsets show|write|restore``: the identified joint offsets onto the controller.

Exit codes: 0 done (or nothing to do), 1 declined at the prompt, 2 bad input, 3 the
controller failed (the message says what it holds), 4 refused as unreliable.
"""

from __future__ import annotations

import contextlib
import json
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from ogacq_drivers.axes.controller import AxisController
from ogacq.campaign.campaign_file import ControllerSpec
from ogacq.campaign.station import open_controller
from ogacq.cli import render_offsets as render
from ogacq.cli.options import (
    AcceptEditedOption,
    HistoryOption,
    JsonOption,
    PartialOption,
    confirmed,
)
from ogacq.cli.plain import print_wrapped
from ogacq.cli.render_fit import print_notes
from ogacq.errors import InputError, OgacqError, Refused
from ogacq.history.recording import record_writebacks
from ogacq.session.state import require_complete, session_notes
from ogacq.session.store import LoadedSession, load_session
from ogacq.writeback.audit import AuditLog, last_write, operations
from ogacq.writeback.evidence import evidence_from_session
from ogacq.writeback.execute import WriteOptions
from ogacq.writeback.offsets_target import ControllerOffsets
from ogacq.writeback.outcome import Stage
from ogacq.writeback.policy import (
    DEFAULT_MAX_CHANGE_MM,
    ControllerFacts,
    OffsetPlan,
    WritePolicy,
    plan_return,
    plan_write,
)
from ogacq.writeback.target import controller_of, session_controller
from ogacq.writeback.write_target import found_in_force
from ogacq.writeback.write_target import restore as restore_target

if TYPE_CHECKING:  # SQLAlchemy is imported when the history is used, not at start-up
    from ogacq.history.location import HistoryLocation

EXIT_DECLINED = 1

SessionArgument = Annotated[Path, typer.Argument(
    help="Session of the calibration campaign (its identified offsets; the audit goes here).")]
CampaignOption = Annotated[Path | None, typer.Option(
    "--campaign", "-c", help="Campaign file whose controller table names the controller; "
                             "default: the one the session was run with.")]
YesOption = Annotated[bool, typer.Option(
    "--yes", "-y", help="Write without asking (scripts).")]
ForceOption = Annotated[bool, typer.Option(
    "--force", help="Write even a result judged unreliable (the reasons are still printed "
                    "and recorded).")]
SaveNvmOption = Annotated[bool, typer.Option(
    "--save-nvm", help="Also save the drive parameters to non-volatile memory (limited write "
                       "endurance: only when asked).")]
NoHomeOption = Annotated[bool, typer.Option(
    "--no-home", help="Do not re-home after writing an offset that takes effect at homing "
                      "(it then acts at the next homing; every campaign homes first).")]
FromDiagnosisOption = Annotated[bool, typer.Option(
    "--from-diagnosis", help="The joint offsets of the diagnosis's final model (the offsets "
                             "with the effects it found beside them); the effects remain.")]
MaxChangeOption = Annotated[float, typer.Option(
    "--max-change-mm", min=0.0, help="Refuse a change of any axis larger than this (mm).")]


def _offer_nvm(plan: OffsetPlan, *, yes: bool) -> bool:
    """Where the drive can save its parameters, ask (not with --yes: only --save-nvm
    saves unattended); say what a power cycle does to values left unsaved."""
    facts = plan.facts
    if facts.kind == "software":
        return False  # the table is a file: it outlives any power cycle
    if not facts.has_nvm:
        typer.echo(f"profile {facts.profile!r} has no non-volatile save: a power cycle of the "
                   "drive brings back the offsets it saved before (save them with the "
                   "drive's own panel or software to keep them)", err=True)
        return False
    if yes:
        return False
    return confirmed("Save them to the drive's non-volatile memory too? Unsaved, switching the "
                "drive off and on brings back the offsets it saved before (the memory "
                "takes a limited number of writes: save only values you keep)")


def _approve(plan: OffsetPlan, audit: AuditLog, spec: ControllerSpec, *, yes: bool,
             force: bool, save_nvm: bool, rehome: bool) -> WriteOptions | None:
    """Refuse, ask: the options to write with, None when there is nothing to write.
    ``audit`` is open: this command holds the session, so no campaign runs on it
    meanwhile."""
    if plan.nothing_to_do:
        print_wrapped(f"the controller already holds these offsets: nothing to {plan.action}")
        return None
    summary = {"action": plan.action, "current_mm": plan.current_mm, "new_mm": plan.new_mm}
    if plan.refused:
        render.print_refusals(plan, forced=force)
    if plan.refused and not force:
        audit.record(Stage.REFUSED, **summary, reasons=[r.message for r in plan.refusals],
                     codes=[r.code for r in plan.refusals])
        raise Refused(f"nothing written; --force {plan.action}s anyway")
    if not yes:
        homing = (" and re-home the axes (the machine moves)"
                  if rehome and plan.facts.takes_effect == "at_next_homing" else "")
        target = ("the software offset table" if plan.facts.kind == "software"
                  else "the controller")
        if not confirmed(f"{plan.action.capitalize()} these offsets to {target}{homing}?"):
            audit.record(Stage.DECLINED, **summary)
            typer.echo("nothing written", err=True)
            raise typer.Exit(EXIT_DECLINED)
    save_nvm = save_nvm or _offer_nvm(plan, yes=yes)
    return WriteOptions(save_nvm=save_nvm, rehome=rehome,
                        forced=tuple(r.code for r in plan.refusals),
                        confirmed_by="--yes" if yes else "prompt", port=spec.port)


def _approve_and_execute(controller: AxisController, plan: OffsetPlan, audit: AuditLog,
                         spec: ControllerSpec, *,
                         yes: bool, force: bool, save_nvm: bool, rehome: bool) -> None:
    """Refuse, ask, then write (pre-flight, written, read back, audited)."""
    options = _approve(plan, audit, spec, yes=yes, force=force, save_nvm=save_nvm,
                       rehome=rehome)
    target = ControllerOffsets(controller, spec.offsets_file, options or WriteOptions())
    if options is None:
        # held already: an earlier write of the session cut short before its done
        # record left them, and the audit (and the history) now say so
        found_in_force(target, audit.session, audit)
        return
    # a WriteBackError (a DriverError) says what the controller holds now
    target.execute(plan, audit, options.confirmed_by)
    assert target.outcome is not None
    render.print_outcome(target.outcome)


def show(
    session_path: SessionArgument,
    campaign_path: CampaignOption = None,
    max_change_mm: MaxChangeOption = DEFAULT_MAX_CHANGE_MM,
    from_diagnosis: FromDiagnosisOption = False,
    partial: PartialOption = False,
    accept_edited: AcceptEditedOption = False,
    as_json: JsonOption = False,
) -> None:
    """Show the controller's offsets, the identified ones (std, fit verdict) and the
    proposed new ones; nothing is written.

    Says whether `ogacq offsets write` would write them, and if not, why.
    """
    session = _analysed(session_path, partial, accept_edited, say=not as_json)
    evidence = evidence_from_session(session, from_diagnosis)
    _, spec, _ = session_controller(session, campaign_path)
    with open_controller(spec) as controller:
        facts = ControllerFacts.of(controller.profile)
        plan = plan_write(evidence, controller.read_offsets(), facts, WritePolicy(max_change_mm))
    history = operations(session)
    if as_json:
        typer.echo(json.dumps({
            "evidence": evidence.to_json(), "plan": plan.to_json(),
            "controller": {"profile": spec.profile, "port": spec.port,
                           "offsets_file": _table_name(spec)},
            "writes": [op.as_mapping() for op in history]}))
        return
    render.print_evidence(evidence)
    render.print_plan(plan, port=spec.port, offsets_file=_table_name(spec), evidence=evidence)
    render.print_history(history)
    if plan.nothing_to_do:
        print_wrapped("the controller already holds these offsets")
    elif plan.refused:
        for refusal in plan.refusals:
            print_wrapped(f"would refuse ({refusal.code}): {refusal.message}")
    else:
        print_wrapped("`ogacq offsets write` would write these")


def _analysed(path: Path, partial: bool, accept_edited: bool, *, say: bool = True,
              ) -> LoadedSession:
    """The session whose offsets are shown or written: refused when edited or not
    finished unless the user said so; what it is then is said first."""
    session = load_session(path, accept_edited=accept_edited)
    state = require_complete(session, partial)
    if say:
        print_notes(session_notes(session, state))
    return session


def _table_name(spec: ControllerSpec) -> str | None:
    return str(spec.offsets_file) if spec.offsets_file else None


def write(
    session_path: SessionArgument,
    campaign_path: CampaignOption = None,
    yes: YesOption = False,
    force: ForceOption = False,
    save_nvm: SaveNvmOption = False,
    no_home: NoHomeOption = False,
    max_change_mm: MaxChangeOption = DEFAULT_MAX_CHANGE_MM,
    from_diagnosis: FromDiagnosisOption = False,
    history: HistoryOption = None,
    partial: PartialOption = False,
    accept_edited: AcceptEditedOption = False,
) -> None:
    """Write the offsets identified by a campaign: shown, confirmed, read back, recorded
    in the session and in the machine's history."""
    session = _analysed(session_path, partial, accept_edited)
    evidence = evidence_from_session(session, from_diagnosis)
    with _recorded_after(session, history), \
            controller_of(session, campaign_path, save_nvm) as (spec, audit, controller):
        plan = plan_write(evidence, controller.read_offsets(),
                          ControllerFacts.of(controller.profile), WritePolicy(max_change_mm))
        render.print_evidence(evidence)
        render.print_plan(plan, port=spec.port, offsets_file=_table_name(spec),
                          evidence=evidence)
        _approve_and_execute(controller, plan, audit, spec, yes=yes, force=force,
                             save_nvm=save_nvm, rehome=not no_home)
    render.print_validation_next(str(campaign_path or session.header.campaign_file or ""),
                                 session.path, from_diagnosis)


RestoreSessionArgument = Annotated[Path | None, typer.Argument(
    help="Session whose last write-back to undo (its audit goes there); leave it out with "
         "--machine and --to.")]
MachineOption = Annotated[str | None, typer.Option(
    "--machine", help="Go back to a state of this machine's history (its name or serial; "
                      "with --to).")]
ToOption = Annotated[str | None, typer.Option(
    "--to", metavar="STATE", help="The offsets state (`ogacq history MACHINE --states`) or the "
                                  "calibration record id whose write-back to go back to.")]
RestoreHistoryOption = Annotated[str | None, typer.Option(
    "--history", metavar="URL_OR_PATH",
    help="The history: an SQLite file or a postgresql://USER@HOST/DB URL (default: "
         "$OGACQ_HISTORY, else history.sqlite in ogacq's data folder: $OGACQ_HOME, default "
         "~/.local/share/ogacq).")]


def restore(
    session_path: RestoreSessionArgument = None,
    campaign_path: CampaignOption = None,
    yes: YesOption = False,
    force: ForceOption = False,
    save_nvm: SaveNvmOption = False,
    no_home: NoHomeOption = False,
    machine: MachineOption = None,
    to: ToOption = None,
    history: RestoreHistoryOption = None,
) -> None:
    """Put back the offsets the session's last write-back replaced, or (--machine NAME
    --to STATE) any offsets state the machine's history recorded.

    Either way: shown, confirmed, written, read back, recorded in the session and the
    history. Going back to a state is refused when the controller holds offsets the
    history does not know (--force overrides).
    """
    if session_path is not None and (machine is not None or to is not None):
        raise InputError("--machine", "give either a SESSION, or --machine and --to, not both")
    if session_path is None:
        if machine is None or to is None:
            raise InputError("--machine" if machine is None else "--to",
                             "is missing: give a SESSION, or --machine NAME --to STATE")
        _restore_state(machine, to, history, campaign_path, yes=yes, force=force,
                       save_nvm=save_nvm, rehome=not no_home)
        return
    session = load_session(session_path)
    operation = last_write(session)
    if operation is None:
        raise InputError(session.path, "no write-back is recorded in this session: nothing "
                         "to restore")
    with _recorded_after(session, history), \
            controller_of(session, campaign_path, save_nvm) as (spec, audit, controller):
        target = ControllerOffsets(controller, spec.offsets_file)
        plan = target.plan_restore(operation, target.held())
        render.print_plan(plan, port=spec.port, offsets_file=_table_name(spec))
        options = _approve(plan, audit, spec, yes=yes, force=force, save_nvm=save_nvm,
                           rehome=not no_home)
        if options is None:
            return
        target.options = options
        # said restored only once the controller, read back, holds the old values
        restore_target(target, operation, session, audit, options.confirmed_by, forced=force)
        if target.outcome is not None:
            render.print_outcome(target.outcome)


def _restore_state(machine_name: str, wanted: str, history: str | None,
                   campaign_path: Path | None, *, yes: bool, force: bool, save_nvm: bool,
                   rehome: bool) -> None:
    """Go back to an offsets state of the machine's history, through the session it
    came from (its campaign names the controller, its audit gets the records)."""
    from ogacq.history.location import history_to_read
    from ogacq.history.store import History

    location = history_to_read(history)
    with History.open(location, create=False) as db:
        found = db.find_machine(machine_name)
        state = db.find_state(found, wanted)
        in_force = db.current_state(found)
    if not state.session_path or not Path(state.session_path).is_file():
        raise InputError(state.session_path or wanted, f"the session of offsets state "
                         f"{state.state_id} is not on this computer: restore from the station "
                         "that holds it")
    session = load_session(Path(state.session_path))
    print_wrapped(f"{found.describe()}: back to offsets state {state.state_id} ({state.stage} "
                  f"{state.action} {state.operation}, {state.at or 'undated'})")
    with _recorded_after(session, history, location), \
            controller_of(session, campaign_path, save_nvm) as (spec, audit, controller):
        try:
            plan = plan_return(state.offsets_mm, state.state_id, controller.read_offsets(),
                               ControllerFacts.of(controller.profile), profile=state.profile,
                               expected_mm=in_force.offsets_mm if in_force else None)
        except ValueError as exc:
            raise InputError(wanted, str(exc)) from None
        render.print_plan(plan, port=spec.port, offsets_file=_table_name(spec))
        _approve_and_execute(controller, plan, audit, spec, yes=yes, force=force,
                             save_nvm=save_nvm, rehome=rehome)


@contextlib.contextmanager
def _recorded_after(session: LoadedSession, history: str | None,
                    location: HistoryLocation | None = None) -> Iterator[None]:
    """Once the session is released, whatever the outcome: when its audit holds a new
    write-back or restore (a declined or refused one wrote nothing; a failed one is
    recorded as failed), the history gets it."""
    before = len(operations(session))
    try:
        yield
    finally:
        edited = bool(session.integrity.edited)  # accepted as it stands: recorded as such
        with contextlib.suppress(OgacqError):  # the session's own error is said already
            if len(operations(load_session(session.path, accept_edited=edited))) > before:
                record_writebacks(session.path, history, location, accept_edited=edited)


